"""``report --sweep`` on stores from elsewhere: an older schema is refused naming what it
lacks; a store that predates a parameter, or was measured by another code version, is
read and marked on the page."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from volcaustics.approx.params import PARAMS, ApproxParams
from volcaustics.experiment.versions import code_version
from volcaustics.infra.storage import file_sha256
from volcaustics.reports.measuring.results.points_table import POINT_COLUMNS, point_row
from volcaustics.reports.measuring.results.store import document_sha256
from volcaustics.reports.presenting.page.report_document import SweepSummary
from volcaustics.reports.presenting.page.sweep_section import sweep_section
from volcaustics.reports.presenting.report.sweep_store import ReportError, load_sweep
from volcaustics.reports.studies.sweep.sweep_run import MANIFEST_SEAL


def _store(folder, drop=(), version=None):
    """A sweep store of two points with this code's schema, less the columns ``drop``."""
    params = ApproxParams().to_dict()
    rows = [{**{c: 0.5 for c in POINT_COLUMNS}, **params, "point": f"p{k}", "scene": "refocus", "layers": k + 1,
             "code_version": version or code_version()} for k in range(2)]
    folder.mkdir()
    pd.DataFrame(rows).drop(columns=list(drop)).to_parquet(folder / "points.parquet")
    for name in ("segments", "photons", "images"):
        pd.DataFrame({"point": ["p0"]}).to_parquet(folder / f"{name}.parquet")
    files = {p.name: file_sha256(str(p)) for p in folder.glob("*.parquet")}  # as the sweep records them
    doc = {"spec": {"vary": {"layers": [1, 2]}}, "points": 2, "files": files}
    doc[MANIFEST_SEAL] = document_sha256(doc, MANIFEST_SEAL)  # as the sweep seals it
    (folder / "sweep.json").write_text(json.dumps(doc))
    return str(folder)


def test_the_schema_is_what_point_row_writes():
    summary = {"scene": "s", "scene_hash": "h", "params": ApproxParams().to_dict(), "seeds": 1,
               "reference": {"key": "k"}, "code_version": "c"}
    assert set(point_row("key", summary)) == set(POINT_COLUMNS) | {p.name for p in PARAMS}


def test_a_store_of_this_code_reads_without_a_note(tmp_path):
    assert load_sweep(_store(tmp_path / "s")).notes == []


def test_an_older_store_is_refused_naming_what_it_lacks(tmp_path):
    folder = _store(tmp_path / "s", drop=("map_reads_per_segment", "share_intersection_se"), version="0ld")
    with pytest.raises(ReportError, match="lacks map_reads_per_segment, share_intersection_se: written by an older "
                                          r"volcaustics \(code version 0ld\); rerun the sweep"):
        load_sweep(folder)


def test_a_store_before_a_parameter_and_of_another_code_version_is_marked(tmp_path):
    sweep = load_sweep(_store(tmp_path / "s", drop=("crossing",), version="0ld"))
    assert list(sweep.tables["points"]["crossing"]) == ["sign", "sign"]  # what its points ran
    assert any("predates the parameter crossing" in n and "crossing = sign" in n for n in sweep.notes)
    assert any(n.startswith("measured by code version 0ld, not this code's") for n in sweep.notes)
    summary = SweepSummary(folder="s", varied=("layers",), spec={}, points=2, suffice=(), point_rows=(),
                           suffice_factor=None, figures=(), variants=None, best=None, notes=tuple(sweep.notes))
    html = sweep_section(summary, {})
    assert html.count("class='warn sweep-note'") == 2 and "predates the parameter crossing" in html


@pytest.mark.parametrize("table", ["points", "images"])
def test_a_table_edited_after_the_sweep_is_refused(tmp_path, table):
    """sweep.json records the SHA-256 of each consolidated table: `report --sweep`
    refuses one edited since (before: its numbers were drawn on the page)."""
    folder = _store(tmp_path / "s")
    path = tmp_path / "s" / f"{table}.parquet"
    frame = pd.read_parquet(path)
    frame["caustic_relmse_debiased" if table == "points" else "value"] = 0.25  # a number edited by hand
    frame.to_parquet(path)
    with pytest.raises(ReportError, match=rf"{table}\.parquet does not match.*sweep\.json.*rerun the sweep"):
        load_sweep(folder)


@pytest.mark.parametrize("edit", [{"points": 3}, {"spec": {"vary": {"iterations": [4, 8]}}}, {"files": {}}])
def test_an_edited_sweep_manifest_is_refused(tmp_path, edit):
    """sweep.json carries the SHA-256 of itself: one edited by hand (its spec, its
    count, its table hashes) is refused, never drawn with the wrong labels."""
    folder = _store(tmp_path / "s")
    path = tmp_path / "s" / "sweep.json"
    path.write_text(json.dumps({**json.loads(path.read_text()), **edit}))
    with pytest.raises(ReportError, match=r"sweep\.json does not match the SHA-256 it records of itself"):
        load_sweep(folder)


def test_a_store_without_table_hashes_is_marked(tmp_path):
    """A store written before sweep.json recorded its tables' hashes is drawn, with a
    note on the page saying its tables are unchecked."""
    folder = _store(tmp_path / "s")
    doc = json.loads((tmp_path / "s" / "sweep.json").read_text())
    del doc["files"], doc[MANIFEST_SEAL]  # an older sweep recorded neither
    (tmp_path / "s" / "sweep.json").write_text(json.dumps(doc))
    assert [n for n in load_sweep(folder).notes if "no SHA-256" in n and "rerun the sweep" in n]
