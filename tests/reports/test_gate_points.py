"""The gate measures what it checks: its points (scope "gate") skip the exact replay,
the decomposition, the model term and the image metrics no budget reads, their key
says so, and a full point that the report stored serves the gate (a superset)."""

from __future__ import annotations

import dataclasses

from tests.shared import FULL_MEASUREMENT, GATE_POINT, GATE_REFERENCE
from volcaustics.experiment.image_rows import IMAGE_METRICS
from volcaustics.experiment.measurement import GATE_IMAGE_METRICS
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.results.store import Store
from volcaustics.reports.studies.gate.budgets import COMPONENT_KEYS

REFERENCE, POINT, FULL = GATE_REFERENCE, GATE_POINT, FULL_MEASUREMENT
LEAN = dataclasses.replace(FULL, scope="gate")


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
