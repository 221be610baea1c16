"""A point measures what its reader checks. The gate's points (scope "gate") skip the exact
replay, the decomposition, the model term and the image metrics no budget reads; the
closure's (scope "decomposition") skip the timed frames, the segments, the photon paths
and the model term and keep the decomposition as a full point has it. Their keys say so,
and a full point that the report stored serves either (a superset)."""

from __future__ import annotations

import dataclasses

from tests.shared import FULL_MEASUREMENT, GATE_POINT, GATE_REFERENCE
from volcaustics.experiment.image_rows import IMAGE_METRICS
from volcaustics.experiment.measurement import GATE_IMAGE_METRICS, MEASUREMENT_PARAMS, SCOPE_PARTS
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.results.store import Store
from volcaustics.reports.studies.gate.budgets import COMPONENT_KEYS

REFERENCE, POINT, FULL = GATE_REFERENCE, GATE_POINT, FULL_MEASUREMENT
LEAN = dataclasses.replace(FULL, scope="gate")
CLOSURE = dataclasses.replace(FULL, scope="decomposition")


def _measure(store, measurement):
    return runner.measure([POINT], store, reference_settings=REFERENCE, measurement=measurement, policy="missing",
                          progress=False)


def test_a_gate_point_skips_the_decomposition_and_is_keyed_apart(cache, tmp_path):
    lean = _measure(Store(str(tmp_path / "lean")), LEAN)
    summary = lean.results[0].summary
    assert lean.computed == 1 and summary["exact"] is None and summary["decomposition"] is None
    assert summary["model"] is None and "exact_images" not in summary["experiment_seconds"]
    assert set(lean.results[0].tables["images"]["metric"]) == set(GATE_IMAGE_METRICS)
    full = _measure(Store(str(tmp_path / "full")), FULL)
    assert full.results[0].summary["decomposition"]["rows"] and full.keys != lean.keys
    # the same images, with and without the decomposition
    images = [r.results[0].tables["images"] for r in (lean, full)]
    relmse = [t[(t["metric"] == "relative_mse") & (t["component"] == "caustic")]["debiased"].item() for t in images]
    assert relmse[0] == relmse[1]


def test_a_full_point_serves_the_gate_and_a_lean_one_does_not_serve_the_report(cache, tmp_path):
    store = Store(str(tmp_path / "store"))
    full = _measure(store, FULL)
    gate = _measure(store, LEAN)
    assert gate.computed == 0 and gate.keys == full.keys and gate.results[0].summary["decomposition"] is not None
    other = Store(str(tmp_path / "other"))
    _measure(other, LEAN)
    report = _measure(other, FULL)
    assert report.computed == 1 and report.results[0].summary["decomposition"] is not None


def test_the_gate_scope_holds_every_metric_a_budget_can_name():
    """COMPONENT_KEYS (the budgets) and GATE_IMAGE_METRICS (what a gate point measures)
    name the same metrics: a budget key without its metric would fail closed on every
    gate point."""
    named = {"relmse_max": "relative_mse", "frame_relmse_max": "frame_relative_mse", "energy_ratio": "energy_ratio",
             "hdr_flip_max": "hdr_flip"}
    assert set(named) == set(COMPONENT_KEYS)
    assert set(named.values()) == set(GATE_IMAGE_METRICS) and set(GATE_IMAGE_METRICS) <= set(IMAGE_METRICS)


def test_a_decomposition_point_holds_the_full_points_decomposition_and_no_timings(cache, tmp_path):
    """What the closure reads is the full point's, to the bit: the record frames do not
    depend on the warm-up and timed frames rendered before and after them (a renderer
    that kept state across frames would fail here); what it skips is absent, not zero."""
    lean = _measure(Store(str(tmp_path / "closure")), CLOSURE)
    full = _measure(Store(str(tmp_path / "full")), FULL)
    assert lean.computed == 1 and lean.keys != full.keys
    summary, whole = lean.results[0].summary, full.results[0].summary
    assert summary["decomposition"] == whole["decomposition"] and summary["exact"]["alive_after"] == whole["exact"][
        "alive_after"]
    assert summary["images"]["caustic"]["relative_mse"] == whole["images"]["caustic"]["relative_mse"]
    assert summary["timed_frames"] == 0 and summary["approx_timings_s"] == {} and whole["timed_frames"] > 0
    assert summary["paths"] is None and summary["model"] is None
    assert not {"segments", "photons"} & set(summary["experiment_seconds"])
    tables = lean.results[0].tables
    assert len(tables["segments"]) == 0 and len(tables["photons"]) == 0
    assert set(IMAGE_METRICS) & set(tables["images"]["metric"]) == set(GATE_IMAGE_METRICS)
    served = _measure(Store(str(tmp_path / "full")), CLOSURE)
    assert served.computed == 0 and served.keys == full.keys


def test_every_scope_says_what_it_measures():
    """The scope's choices and SCOPE_PARTS name the same scopes; a full point measures every
    part (so it serves any other scope), and the others each a part of it."""
    choices = next(p.choices for p in MEASUREMENT_PARAMS if p.name == "scope")
    assert set(choices) == set(SCOPE_PARTS)
    assert all(parts <= SCOPE_PARTS["full"] for parts in SCOPE_PARTS.values())
