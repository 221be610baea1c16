"""The frame check's table (reports.studies.best.frame_check): ratios against each scene's paper
configuration without a denoiser, the verdict apart for built-in and held-out scenes
(a configuration that wins only where it was chosen is not met: the negative control),
and the report's section showing it."""

from __future__ import annotations

import json
import re

import pandas as pd
import pytest

from volcaustics.reports.presenting.page.frame_check_section import frames_rows, frames_section
from volcaustics.reports.studies.best.frame_check import verdict, with_ratios


def _row(scene, heldout, config, denoise, frame, mean=0.05, cost=100.0):
    return {"scene": scene, "heldout": heldout, "config": config, "denoise": denoise, "photon_res": 256,
            "frame_cost": cost, "frame_relmse": frame, "frame_relmse_se": 0.001, "relmse_debiased": mean,
            "relmse_se": 0.001, "denoise_s": 0.3 if denoise == "oidn" else None}


def _table(heldout_best: float, more: list | None = None) -> pd.DataFrame:
    rows = list(more or [])
    for scene, heldout, best in (("a", False, 0.04), ("b", False, 0.05), ("k", True, heldout_best)):
        rows += [_row(scene, heldout, "paper", "none", 0.10), _row(scene, heldout, "paper", "oidn", 0.09),
                 _row(scene, heldout, "best", "none", best, cost=99.0), _row(scene, heldout, "best", "oidn", best)]
    return with_ratios(pd.DataFrame(rows))


def test_best_meets_the_goal_only_when_it_holds_on_the_heldout_scenes_too():
    good = verdict(_table(0.045))
    assert good["met"] and good["none_builtin_worst_frame_ratio"] == 0.5
    bad = verdict(_table(0.20))  # half on the built-ins, twice the paper's held out
    assert not bad["met"] and bad["none_builtin_worst_frame_ratio"] == 0.5
    assert bad["none_heldout_worst_frame_ratio"] == 2.0


def test_beams_worst_ratios_stand_beside_bests_verdict_which_they_do_not_change():
    """The frame check's beams rows (the preset beams) get their own worst ratios
    (``beams_…``) and a line in the report; best's verdict is best's alone: beams at
    twice the paper's on a held-out scene leave a met verdict met."""
    beams = [_row(scene, heldout, "beams", "none", frame, cost=98.0)
             for scene, heldout, frame in (("a", False, 0.02), ("b", False, 0.03), ("k", True, 0.20))]
    table = _table(0.045, more=beams)
    v = verdict(table)
    assert v["met"] and v["beams_none_builtin_worst_frame_ratio"] == 0.3
    assert v["beams_none_heldout_worst_frame_ratio"] == 2.0 and "beams_oidn_builtin_worst_frame_ratio" not in v
    html = frames_section({"rows": frames_rows(table), "verdict": v})
    assert "beams' worst one-frame ratio without a denoiser: 0.30× on the built-ins, 2.00× on the held-out" in html


def test_the_report_section_shows_every_row_and_the_verdict():
    table = _table(0.045)
    html = frames_section({"rows": frames_rows(table), "verdict": verdict(table)})
    assert html.count("<tr>") == len(table) + 1 and "(held out)" in html and "<b>met</b>" in html
    assert frames_section(None) == ""


def test_the_manifest_is_strict_json_when_a_ratio_is_not_a_number(tmp_path):
    """frames.json once held bare NaN tokens (a scene whose time or caustic error was not
    a number), which JSON readers refuse; now null."""
    from volcaustics.reports.studies.best.frame_check import MANIFEST, write_manifest

    write_manifest(str(tmp_path), {"kind": "frames", "verdict": {"none_builtin_worst_time_ratio": float("nan")}})
    text = (tmp_path / MANIFEST).read_text()
    assert "NaN" not in text and json.loads(text)["verdict"]["none_builtin_worst_time_ratio"] is None


def test_a_stored_point_is_reused_only_under_its_own_key(tmp_path):
    """An interrupted frame check resumes: a point is kept under a key of its scene,
    parameters, seeds and code version; another key (a changed parameter) measures again."""
    import dataclasses

    from volcaustics.approx.params import preset
    from volcaustics.reports.studies.best.frame_check import point_key, store_point, stored_point
    from volcaustics.scenes import load_builtin

    scene = load_builtin("refocus")
    params = preset("quick")
    key = point_key(scene, params, 6, "v1")
    store_point(str(tmp_path), key, {"scene": "refocus", "frame_relmse": 0.1})
    assert stored_point(str(tmp_path), key) == {"scene": "refocus", "frame_relmse": 0.1}
    for other in (point_key(scene, dataclasses.replace(params, steps=6), 6, "v1"), point_key(scene, params, 4, "v1"),
                  point_key(scene, params, 6, "v2")):
        assert other != key and stored_point(str(tmp_path), other) is None


def _frame_check(folder, manifest_changes=None, drop=None) -> str:
    """A frame check's folder as ``volcaustics frames`` writes it, then changed."""
    from volcaustics.reports.studies.best.frame_check import FRAMES_FILE, KIND, MANIFEST, SCHEMA, write_manifest

    table = _table(0.045)
    folder.mkdir(exist_ok=True)
    table.drop(columns=drop or []).to_parquet(folder / FRAMES_FILE, index=False)
    manifest = {"kind": KIND, "schema": SCHEMA, "verdict": verdict(table)}
    write_manifest(str(folder), manifest)
    if manifest_changes is not None:
        doc = json.loads((folder / MANIFEST).read_text())
        (folder / MANIFEST).write_text(json.dumps(manifest_changes(doc)))
    return str(folder)


@pytest.mark.parametrize("change, drop, message", [
    (lambda d: [d], None, "expected a JSON object"),
    (lambda d: {k: v for k, v in d.items() if k != "verdict"}, None, "verdict = None"),
    (lambda d: {**d, "verdict": {**d["verdict"], "goal": "half"}}, None, "expected an object with a number goal"),
    (lambda d: {**d, "schema": True}, None, "schema = True: expected 1"),
    (lambda d: {k: v for k, v in d.items() if k != "kind"}, None, "kind = None: expected 'frames'"),
    (None, ["frame_ratio"], "no column 'frame_ratio'"),
])
def test_a_frame_check_read_back_is_checked_against_its_shape(tmp_path, capsys, change, drop, message):
    """`report --frames` once trusted frames.json and frames.parquet by key (a KeyError
    after measuring); each damage is refused naming the file and what was expected, and
    the intact folder loads (the negative control)."""
    from volcaustics.reports.cli import main
    from volcaustics.reports.studies.best.frame_check import load_frames

    table, _ = load_frames(_frame_check(tmp_path / "good"))
    assert len(table) == 12
    folder = _frame_check(tmp_path / "bad", change, drop)
    with pytest.raises(ValueError, match=re.escape(message)):
        load_frames(folder)
    assert main(["report", "--frames", folder, "--out", str(tmp_path / "report"), "--scenes", "sphere1"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and not (tmp_path / "report").exists()
