"""The variants view of a sweep (reports/studies/sweep/variants.py) and sweep specs with
several grids ([[vary]]), on tables built by hand."""

from __future__ import annotations

import pandas as pd
import pytest

from volcaustics.approx.params import PAPER
from volcaustics.reports.studies.sweep.sweep_spec import SweepError, points, spec_from_toml
from volcaustics.reports.studies.sweep.variants import best_variants, draw_variants, variant_table


def _tables(rows):
    """points and segments tables for (point, search, start_rule, reads, share, wrong, missed[,
    relMSE part: else share / 2])."""
    points, segments = [], []
    for key, search, rule, reads, share, wrong, missed, *relmse in rows:
        points.append({"point": key, "scene": "bunny", "search": search, "start_rule": rule,
                       "layer_strategy": PAPER.layer_strategy, "layers": PAPER.layers,
                       "peak_samples": PAPER.peak_samples, "iterations": PAPER.iterations,
                       "map_reads_per_segment": reads, "frame_time_s": 1.0, "share_intersection": share,
                       "share_intersection_se": 0.005,
                       "intersection_relmse_part": relmse[0] if relmse else abs(share) / 2,
                       "intersection_relmse_part_se": 0.001})
        segments.append({"point": key, "grouping": "step", "step": 2, "segments": 100,
                         "count_true_hit": 100 - wrong - missed, "count_wrong_surface": wrong,
                         "count_false_hit": 0, "count_missed_inside": missed, "count_missed_medium": 0})
    return {"points": pd.DataFrame(points), "segments": pd.DataFrame(segments)}


ROWS = [("p", "bisection", "offset", 190.0, 0.12, 17, 3),   # the paper's method
        ("a", "secant", "offset", 150.0, 0.05, 8, 2),       # cheaper and better: the best
        ("b", "dda", "offset", 400.0, 0.01, 2, 1),          # better still, but dearer than the paper's
        ("c", "hiz", "id", 180.0, -0.09, 12, 6)]


def test_best_variant_is_the_smallest_term_within_the_papers_reads():
    table = variant_table(_tables(ROWS))
    assert table.loc[table["paper"], "point"].tolist() == ["p"]
    assert table.set_index("point").loc["c", "step2_missed"] == pytest.approx(6.0)
    best = best_variants(table).set_index("role")
    assert best.loc["best", "point"] == "a"  # not b: more map reads than the paper's
    assert best.loc["best", "share_ratio"] == pytest.approx(0.05 / 0.12)
    assert best.loc["best", "relmse_ratio"] == pytest.approx(0.025 / 0.06)
    assert set(table.loc[table["pareto"], "point"]) == {"a", "b"}


def test_a_small_energy_share_from_cancelling_errors_is_not_the_best():
    """Negative control: a variant whose energy share is near zero but whose relative-MSE part
    exceeds the paper's (lost photons cancelling surplus hits) is not chosen over one that
    lowers both parts."""
    rows = [*ROWS, ("d", "bisection", "facing", 160.0, 0.005, 15, 35, 0.08)]
    best = best_variants(variant_table(_tables(rows))).set_index("role")
    assert best.loc["best", "point"] == "a"
    assert best.loc["best", "worse_ratio"] == pytest.approx(max(0.05 / 0.12, 0.025 / 0.06))


def test_negative_control_a_dearer_better_variant_is_not_chosen():
    """Make the cheap variant worse than the paper: the paper's point is the best within its reads."""
    rows = [ROWS[0], ("a", "secant", "offset", 150.0, 0.30, 30, 2), ROWS[2]]
    best = best_variants(variant_table(_tables(rows))).set_index("role")
    assert best.loc["best", "point"] == "p" and best.loc["best", "share_ratio"] == pytest.approx(1.0)


def test_draw_variants_writes_a_figure_per_scene(tmp_path):
    paths = draw_variants(variant_table(_tables(ROWS)), str(tmp_path))
    assert paths and all(tmp_path.joinpath(p).exists() or __import__("os").path.exists(p) for p in paths)


def test_several_grids_join_and_run_a_point_once(tmp_path):
    spec_file = tmp_path / "v.toml"
    spec_file.write_text('scenes = ["sphere1"]\n[[vary]]\nsearch = ["bisection", "dda"]\n'
                         '[[vary]]\nsearch = ["dda", "hiz"]\nstart_rule = ["offset", "id"]\n')
    spec = spec_from_toml(str(spec_file))
    combos = [(p.params.search, p.params.start_rule) for p in points(spec)]
    assert combos == [("bisection", "offset"), ("dda", "offset"), ("dda", "id"), ("hiz", "offset"), ("hiz", "id")]
    assert dict(spec.vary) == {"search": ("bisection", "dda", "hiz"), "start_rule": ("offset", "id")}
    bad = tmp_path / "bad.toml"
    bad.write_text('[[vary]]\nsearch = ["bfs"]\n')
    with pytest.raises(SweepError, match="search"):
        spec_from_toml(str(bad))


def test_the_shipped_variants_spec_loads():
    import os

    from volcaustics.reports.studies.sweep import sweep_spec as spec_module

    path = os.path.join(os.path.dirname(spec_module.__file__), "variants.toml")
    spec = spec_from_toml(path)
    from volcaustics.scenes import BUILTIN_NAMES

    assert sorted(spec.scenes) == sorted(BUILTIN_NAMES)  # every built-in (in the order worth waiting for)
    searches = {p.params.search for p in points(spec)}
    assert searches == {"bisection", "secant", "dda", "hiz"}
    assert {p.params.start_rule for p in points(spec)} == {"offset", "id", "facing"}
    paper = {name: getattr(PAPER, name) for name in ("search", "start_rule", "layer_strategy", "layers",
                                                     "peak_samples", "iterations")}
    assert any(all(getattr(p.params, k) == v for k, v in paper.items()) for p in points(spec))


def test_the_report_shows_the_best_variants():
    """The page's Variants table (reports/presenting/page/html.py) shows each scene's paper point and
    best variant with their numbers; a sweep that varies no variant choice shows none."""
    from volcaustics.reports.measuring.results.tables import rows_of
    from volcaustics.reports.presenting.page.sweep_section import variants_table

    best = rows_of(best_variants(variant_table(_tables(ROWS))))
    html = variants_table({"best": best, "points": []})
    assert "id='variants-best'" in html and "threshold / secant / offset" in html
    assert "+5.0% ± 0.5" in html and "0.42×" in html  # the best's term and its ratio to the paper's
    assert variants_table(None) == ""
