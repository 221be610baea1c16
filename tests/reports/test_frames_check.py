"""The frame check's table (reports.studies.best.frame_check): ratios against each scene's paper
configuration without a denoiser, the verdict apart for built-in and held-out scenes
(a configuration that wins only where it was chosen is not met: the negative control),
and the report's section showing it."""

from __future__ import annotations

import json
import os
import re

import pandas as pd
import pytest

from volcaustics.reports.presenting.page.frame_check_section import frames_rows, frames_section
from volcaustics.reports.presenting.page.report_document import FramesSummary
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
    html = frames_section(FramesSummary(tuple(frames_rows(table)), v, "frames"))
    assert "beams' worst one-frame ratio without a denoiser: 0.30× on the built-ins, 2.00× on the held-out" in html


def test_the_report_section_shows_every_row_and_the_verdict():
    table = _table(0.045)
    html = frames_section(FramesSummary(tuple(frames_rows(table)), verdict(table), "frames"))
    assert html.count("<tr>") == len(table) + 1 and "(held out)" in html and "<b>met</b>" in html
    assert frames_section(None) == ""


def test_the_manifest_is_strict_json_when_a_ratio_is_not_a_number(tmp_path):
    """frames.json once held bare NaN tokens (a scene whose time or caustic error was not
    a number), which JSON readers refuse; now null."""
    from volcaustics.reports.studies.best.frame_check import MANIFEST, write_frames

    verdict_of_nan = {"none_builtin_worst_time_ratio": float("nan")}
    write_frames(str(tmp_path), _table(0.045), {"kind": "frames", "verdict": verdict_of_nan})
    text = (tmp_path / MANIFEST).read_text()
    assert "NaN" not in text and json.loads(text)["verdict"]["none_builtin_worst_time_ratio"] is None


def _frame_check(folder, manifest_changes=None, drop=None, table=None) -> str:
    """A frame check's folder as ``volcaustics frames`` writes it (``table``, default
    best at 0.45× the paper's everywhere), then changed."""
    from volcaustics.reports.studies.best.frame_check import KIND, MANIFEST, SCHEMA, write_frames

    table = _table(0.045) if table is None else table
    manifest = {"kind": KIND, "schema": SCHEMA, "verdict": verdict(table)}
    write_frames(str(folder), table.drop(columns=drop or []), manifest)
    if manifest_changes is not None:
        doc = json.loads((folder / MANIFEST).read_text())
        (folder / MANIFEST).write_text(json.dumps(manifest_changes(doc)))
    return str(folder)


@pytest.mark.parametrize("change, drop, message", [
    (lambda d: [d], None, "expected a JSON object"),
    (lambda d: {k: v for k, v in d.items() if k != "verdict"}, None, "verdict = None"),
    (lambda d: {**d, "verdict": {**d["verdict"], "goal": "half"}}, None, "expected an object with a number goal"),
    (lambda d: {**d, "schema": True}, None, "schema = True: expected 2"),
    (lambda d: {**d, "schema": 1}, None, "schema = 1: expected 2"),  # an older frames.json: no SHA-256s
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


def test_another_runs_table_beside_the_manifest_is_refused_before_any_work(tmp_path, capsys):
    """frames.parquet and frames.json are one set: the manifest records the table's
    SHA-256 and its own. Another run's table beside it (the two were renamed apart), or a
    verdict edited by hand, is refused naming the file, before the report measures
    anything (it once crashed after measuring, and drew no report)."""
    import shutil

    from volcaustics.reports.cli import main
    from volcaustics.reports.studies.best.frame_check import FRAMES_FILE, MANIFEST, load_frames

    met = _frame_check(tmp_path / "met")
    not_met = _frame_check(tmp_path / "not_met", table=_table(0.20))
    assert load_frames(met)[1]["verdict"]["met"] and not load_frames(not_met)[1]["verdict"]["met"]
    shutil.copyfile(tmp_path / "not_met" / FRAMES_FILE, tmp_path / "met" / FRAMES_FILE)
    edited = _frame_check(tmp_path / "edited", table=_table(0.20),
                          manifest_changes=lambda d: {**d, "verdict": {**d["verdict"], "met": True}})
    for folder, name in ((met, FRAMES_FILE), (edited, MANIFEST)):
        with pytest.raises(ValueError, match=re.escape(name) + ".*SHA-256"):
            load_frames(folder)
        out = tmp_path / f"report_{name}"
        assert main(["report", "--frames", folder, "--out", str(out), "--scenes", "sphere1"]) == 2
        err = capsys.readouterr().err
        assert "SHA-256" in err and "Traceback" not in err and not out.exists(), err


def test_the_report_section_shows_a_missing_number_as_a_dash(tmp_path):
    """A scene without its paper row has no ratios (NaN in the table, null in frames.json's
    verdict): the section draws "–" where the number is missing (it formatted None with
    ``:.3f`` and the report died after measuring)."""
    from volcaustics.reports.studies.best.frame_check import load_frames

    table = _table(0.045)
    measured = table[~((table["scene"] == "k") & (table["config"] == "paper"))][list(_row("k", True, "", "", 0))]
    table, manifest = load_frames(_frame_check(tmp_path / "frames", table=with_ratios(measured)))
    assert manifest["verdict"]["none_heldout_worst_frame_ratio"] is None
    html = frames_section(FramesSummary(tuple(frames_rows(table)), manifest["verdict"], "frames"))
    assert html.count("<tr>") == len(table) + 1 and "– on the held-out scenes" in html
    k_best = next(row for row in html.split("<tr>") if row.startswith("<td class='l'>k") and ">best<" in row)
    assert k_best.count("<td>–</td>") == 4, k_best  # cost, time, one frame's and the mean's ratios


def test_a_heldout_scene_named_by_its_path_in_the_checkout_is_held_out():
    """A held-out scene given as the checkout's file (what a user types: scenes/heldout/…)
    is grouped as held out, though the installed package names it through a link (a strict
    editable install: it was grouped as "yours")."""
    from tests.shared import ROOT
    from volcaustics.reports.studies.best.frame_check import checked_scenes

    path = os.path.join(ROOT, "scenes", "heldout", "knot.toml")
    assert [group for _, _, group in checked_scenes([path, "sphere1"], 2)] == ["heldout", "builtin"]


def test_a_media_scene_by_name_or_by_its_path_is_a_media_scene():
    """fogbank by name and smoke by the checkout's file are the media group (the CLI's
    "(medium)"), not a user's scene; the report's section labels the group and gives its
    worst ratio."""
    from tests.shared import ROOT
    from volcaustics.reports.studies.best.frame_check import checked_scenes

    path = os.path.join(ROOT, "scenes", "media", "smoke.toml")
    assert [group for _, _, group in checked_scenes(["fogbank", path], 2)] == ["media", "media"]
    rows = [{**_row("fogbank", False, config, "none", frame), "group": "media"}
            for config, frame in (("paper", 0.10), ("best", 0.06))]
    table = _table(0.045, more=rows)
    html = frames_section(FramesSummary(tuple(frames_rows(table)), verdict(table), "frames"))
    assert "(medium)" in html and "in the media scenes" in html
