"""The report and the gate measure their points on one local process per core
(``runner.measure(parallel=True)``): the same stored results as in this process, and
a point that fails on a worker fails the run, naming its scene."""

from __future__ import annotations

import dataclasses
import os

import pytest

from tests.shared import FULL_MEASUREMENT as FULL
from tests.shared import GATE_POINT as POINT
from tests.shared import GATE_REFERENCE as REFERENCE
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.results.store import TABLES, Store

POINTS = [POINT, runner.Point(POINT.scene, dataclasses.replace(POINT.params, layers=2), seeds=POINT.seeds)]


def _measure(store, **options):
    return runner.measure(POINTS, store, reference_settings=REFERENCE, measurement=FULL, policy="missing",
                          images=("views",), progress=False, **options)


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_parallel_points_store_what_this_process_stores(cache, tmp_path, monkeypatch):
    monkeypatch.setattr(runner, "default_workers", lambda: 2)
    monkeypatch.setattr(runner, "TOOLS", {})  # this process's renderers: none made when the workers measure
    parallel = _measure(Store(str(tmp_path / "parallel")), parallel=True)
    assert parallel.computed == 2 and runner.TOOLS == {}
    here = _measure(Store(str(tmp_path / "here")))
    assert here.keys == parallel.keys and runner.TOOLS
    for key in here.keys:
        for table in TABLES:
            files = [os.path.join(tmp_path, side, "points", key, f"{table}.parquet") for side in ("parallel", "here")]
            with open(files[0], "rb") as a, open(files[1], "rb") as b:
                assert a.read() == b.read(), (key, table)


def test_a_point_failing_on_a_worker_fails_the_run(cache, tmp_path, monkeypatch):
    monkeypatch.setattr(runner, "default_workers", lambda: 2)
    monkeypatch.setattr(runner, "_on_executor", lambda tasks, store, pool, **_: [
        {"key": t.key, "error": "RuntimeError: out of memory"} for t in tasks])
    with pytest.raises(runner.RunnerError, match="refocus: its point failed on a worker process: RuntimeError"):
        _measure(Store(str(tmp_path / "store")), parallel=True)


def test_points_whose_images_fit_the_memory_only_one_at_a_time_run_in_this_process(cache, tmp_path, monkeypatch):
    """``check_frame`` gives one point the whole memory budget: two such points at once
    could exhaust the machine, so they run one after another here."""
    from volcaustics.experiment.point_checks import measurement_bytes

    one = measurement_bytes(32, 32, POINT.seeds)
    monkeypatch.setattr(runner, "default_workers", lambda: 2)
    monkeypatch.setattr(runner, "memory_budget", lambda: int(1.5 * one))
    monkeypatch.setattr(runner, "TOOLS", {})
    assert _measure(Store(str(tmp_path / "store")), parallel=True).computed == 2
    assert runner.TOOLS  # measured in this process


def test_a_worker_reads_only_the_render_its_point_names(cache, tmp_path):
    """A worker takes its reference from the cache by key and content (the EXR's SHA-256
    in the point's key): an entry continued under the key since is not served."""
    from volcaustics.reference.cache import cached_reference
    from volcaustics.scenes import resolve_scene

    scene = resolve_scene(POINT.scene)
    run = _measure(Store(str(tmp_path / "store")))
    key = run.results[0].summary["reference"]["key"]
    content = cached_reference(key, scene).manifest["exr_sha256"]
    assert cached_reference(key, scene, content) is not None
    assert cached_reference(key, scene, "0" * 64) is None
