"""The gate measures what it checks: its points skip the exact replay and the
decomposition (no budget reads them), their key says so, and a full point that the
report stored serves the gate (a superset)."""

from __future__ import annotations

import dataclasses

from volcaustics.approx.params import QUICK
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports import runner
from volcaustics.reports.core.store import Store
from volcaustics.reports.experiment.measurement import MeasurementSettings

REFERENCE = ReferenceSettings(photons=1 << 16, spp=8, batches=4, target_noise=None, max_scatter=1)
POINT = runner.Point("refocus", dataclasses.replace(QUICK, width=32, height=32, photon_res=64, light_res=64), seeds=2)
FULL = MeasurementSettings(exact_subphotons=1)
LEAN = dataclasses.replace(FULL, decomposition=False)


def _measure(store, measurement):
    return runner.measure([POINT], store, reference_settings=REFERENCE, measurement=measurement, policy="missing",
                          progress=False)


def test_a_gate_point_skips_the_decomposition_and_is_keyed_apart(cache, tmp_path):
    lean = _measure(Store(str(tmp_path / "lean")), LEAN)
    summary = lean.results[0].summary
    assert lean.computed == 1 and summary["exact"] is None and summary["decomposition"] is None
    assert "exact_images" not in summary["experiment_seconds"]
    assert set(lean.results[0].tables["images"]["metric"]) >= {"relative_mse", "energy_ratio", "hdr_flip"}
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
