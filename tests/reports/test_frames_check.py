"""The frame check's table (reports.sweep.frames): ratios against each scene's paper
configuration without a denoiser, the verdict apart for built-in and held-out scenes
(a configuration that wins only where it was chosen is not met: the negative control),
and the report's section showing it."""

from __future__ import annotations

import json

import pandas as pd

from volcaustics.reports.page.frames import frames_rows, frames_section
from volcaustics.reports.sweep.frames import verdict, with_ratios


def _row(scene, heldout, config, denoise, frame, mean=0.05, cost=100.0):
    return {"scene": scene, "heldout": heldout, "config": config, "denoise": denoise, "photon_res": 256,
            "frame_cost": cost, "frame_relmse": frame, "frame_relmse_se": 0.001, "relmse_debiased": mean,
            "relmse_se": 0.001, "denoise_s": 0.3 if denoise == "oidn" else None}


def _table(heldout_best: float) -> pd.DataFrame:
    rows = []
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


def test_the_report_section_shows_every_row_and_the_verdict():
    table = _table(0.045)
    html = frames_section({"rows": frames_rows(table), "verdict": verdict(table)})
    assert html.count("<tr>") == len(table) + 1 and "(held out)" in html and "<b>met</b>" in html
    assert frames_section(None) == ""


def test_the_manifest_is_strict_json_when_a_ratio_is_not_a_number(tmp_path):
    """frames.json once held bare NaN tokens (a scene whose time or caustic error was not
    a number), which JSON readers refuse; now null."""
    from volcaustics.reports.sweep.frames import MANIFEST, write_manifest

    write_manifest(str(tmp_path), {"kind": "frames", "verdict": {"none_builtin_worst_time_ratio": float("nan")}})
    text = (tmp_path / MANIFEST).read_text()
    assert "NaN" not in text and json.loads(text)["verdict"]["none_builtin_worst_time_ratio"] is None


def test_a_stored_point_is_reused_only_under_its_own_key(tmp_path):
    """An interrupted frame check resumes: a point is kept under a key of its scene,
    parameters, seeds and code version; another key (a changed parameter) measures again."""
    import dataclasses

    from volcaustics.approx.params import preset
    from volcaustics.reports.sweep.frames import point_key, store_point, stored_point
    from volcaustics.scenes import load_builtin

    scene = load_builtin("refocus")
    params = preset("quick")
    key = point_key(scene, params, 6, "v1")
    store_point(str(tmp_path), key, {"scene": "refocus", "frame_relmse": 0.1})
    assert stored_point(str(tmp_path), key) == {"scene": "refocus", "frame_relmse": 0.1}
    for other in (point_key(scene, dataclasses.replace(params, steps=6), 6, "v1"), point_key(scene, params, 4, "v1"),
                  point_key(scene, params, 6, "v2")):
        assert other != key and stored_point(str(tmp_path), other) is None
