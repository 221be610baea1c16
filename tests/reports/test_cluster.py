"""A sweep on a real Dask cluster whose machines share no disk: a `dask scheduler` and two
`dask worker` processes on loopback, each worker with a cache of its own, none holding
the sweep's references. The references' batches render on the workers and come back
as arrays; the points travel out with their reference and come back as files the
sweep's process stores; before, every point failed ("reference ... is not in this
worker's cache")."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest

from tests.shared import SWEEP_TABLES
from volcaustics.reports.cli import main

SPEC = """
scenes = ["refocus", "sphere1"]
seeds = 1
[vary]
layers = [1, 2, 4]
""" + SWEEP_TABLES


def _dask(*args, env=None, cwd=None) -> subprocess.Popen:
    command = [os.path.join(os.path.dirname(sys.executable), "dask"), *args]
    return subprocess.Popen(command, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


@pytest.fixture
def cluster(tmp_path):
    """(scheduler address, the workers' cache folders, the worker processes, their pids,
    the scheduler process): a scheduler and two one-thread workers on 127.0.0.1, each
    worker in a folder and a cache of its own."""
    file = tmp_path / "scheduler.json"
    processes = [_dask("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                       "--scheduler-file", str(file))]
    caches = []
    try:
        for deadline in (time.monotonic() + 60,):
            while not file.exists() and time.monotonic() < deadline:
                time.sleep(0.2)
        address = json.loads(file.read_text())["address"]
        for i in range(2):
            home = tmp_path / f"worker{i}"
            home.mkdir()
            caches.append(home / "cache")
            env = {**os.environ, "VOLCAUSTICS_CACHE": str(caches[-1])}
            processes.append(_dask("worker", address, "--nthreads", "1", "--no-dashboard", "--name", f"w{i}",
                                   env=env, cwd=str(home)))
        from dask.distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=120)
            pids = set(client.run(os.getpid).values())
        yield address, caches, processes[1:], pids, processes[0]
    finally:
        for process in processes:  # killed: a graceful shutdown of the nannies took 8 s a test
            if process.poll() is None:
                process.kill()
        for process in processes:
            process.wait(timeout=30)


@pytest.mark.slow  # a scheduler, two workers and six small points: about a minute on 2 cores
def test_a_sweep_runs_on_workers_that_share_no_cache(cluster, empty_cache, tmp_path, capsys):
    address, worker_caches, _, worker_pids, _ = cluster
    spec = tmp_path / "sweep.toml"
    spec.write_text(SPEC)
    out = tmp_path / "store"
    assert main(["sweep", str(spec), "-o", str(out), "--dask", address, "--quiet"]) == 0
    assert "6 points: 0 already in the store, 6 computed, 0 failed" in capsys.readouterr().out
    assert len(list((out / "points").iterdir())) == 6
    # the references' batches rendered on the workers, not in the sweep's process
    manifests = [json.loads(p.read_text()) for p in (empty_cache / "reference").glob("*.json")]
    assert len(manifests) == 2
    rendered_by = {int(name.rsplit(":", 1)[1]) for m in manifests for name in m["rendered_by"]}
    assert rendered_by <= worker_pids and os.getpid() not in rendered_by and rendered_by
    # the workers read no reference from their disks and wrote no point there
    for cache in worker_caches:
        assert not (cache / "reference").exists() or not any((cache / "reference").iterdir())
    # resuming measures nothing
    assert main(["sweep", str(spec), "-o", str(out), "--dask", address, "--quiet"]) == 0
    assert "6 already in the store, 0 computed" in capsys.readouterr().out


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_point_sent_back_is_stored_whole_or_refused(tmp_path, cache, capsys):
    """What a worker sends back is put in the store only when its files match its
    summary: a byte changed on the way is refused and nothing is stored (negative control)."""
    from volcaustics.reports.measuring.results.store import Store

    spec = tmp_path / "sweep.toml"
    spec.write_text(SPEC.replace('["refocus", "sphere1"]', '["refocus"]').replace("[1, 2, 4]", "[1]"))
    assert main(["sweep", str(spec), "-o", str(tmp_path / "here"), "--quiet"]) == 0
    store = Store(str(tmp_path / "here"))
    (key,) = [p.name for p in (tmp_path / "here" / "points").iterdir()]
    files = store.point_files(key)
    damaged = dict(files)
    name = next(n for n in files if n.endswith(".parquet"))
    damaged[name] = files[name][:-1] + bytes([files[name][-1] ^ 1])
    other = Store(str(tmp_path / "there"))
    with pytest.raises(OSError, match="do not match its summary"):
        other.adopt_point(key, damaged)
    assert other.status(key) == "missing" and not [p for p in (tmp_path / "there" / "points").iterdir()]
    assert other.adopt_point(key, files) == "written" and other.status(key) == "done"


@pytest.mark.slow  # a cluster and six small points, one worker killed: about a minute each
@pytest.mark.parametrize("task", ["point", "batch"])
def test_a_worker_killed_mid_sweep_loses_nothing_and_stores_nothing_half_written(task, cluster, empty_cache,
                                                                                 tmp_path):
    """SIGKILL one worker while it measures a point, or renders a reference's batch: the
    scheduler gives its tasks to the other worker, so the sweep finishes every point
    (exit 0), or reports the lost ones failed (exit 1); every point in the store and every
    reference in the cache is whole, and a rerun completes the rest."""

    from volcaustics.reference import cache
    from volcaustics.reports.measuring.results.store import Store

    address, _, workers, _, _ = cluster
    spec = tmp_path / "sweep.toml"
    spec.write_text(SPEC)
    out = tmp_path / "store"
    sweep = _sweep_process(spec, out, address)
    caught = _wait_until_busy(address, sweep, task, worker="w0")
    workers[0].kill()
    assert caught, f"the sweep ended before worker w0 took a {task}: nothing was killed mid-{task}"
    output, _ = sweep.communicate(timeout=600)
    assert sweep.returncode in (0, 1), output
    store = Store(str(out))
    points = [p.name for p in (out / "points").iterdir()]
    assert all(store.status(key) == "done" for key in points), output   # nothing half-written
    if sweep.returncode == 0:
        assert len(points) == 6, output
    references = [p.stem for p in (empty_cache / "reference").glob("*.json")]
    assert all(cache.load(key) is not None for key in references), output  # stored whole, or not at all
    if sweep.returncode == 0:
        assert len(references) == 2, output
    assert main(["sweep", str(spec), "-o", str(out), "--dask", address, "--quiet"]) == 0  # the survivor finishes
    assert len(list((out / "points").iterdir())) == 6


def _sweep_process(spec, out, address) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "volcaustics", "sweep", str(spec), "-o", str(out), "--dask",
                             address, "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _wait_until_busy(address, sweep, task: str, worker: str | None = None) -> bool:
    """Whether a worker (named ``worker``, or any) took a ``task`` ("point", "batch")
    of the sweep before it ended, waiting at most 240 s. The workers' names and their
    tasks are read in one call on the scheduler: read in two, a worker that left
    between them was a KeyError (seen once in CI)."""
    from dask.distributed import Client

    def busy_names(dask_scheduler) -> list[str]:
        return [str(ws.name) for ws in dask_scheduler.workers.values()
                if any(str(ts.key).startswith(f"volcaustics-{task}-") for ts in ws.processing)]

    with Client(address, timeout="30s") as client:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and sweep.poll() is None:
            names = client.run_on_scheduler(busy_names)
            if names and (worker is None or worker in names):
                return True
            time.sleep(0.05)
    return False


@pytest.mark.slow  # a cluster and six small points, its scheduler killed: about a minute
def test_a_scheduler_lost_mid_sweep_ends_in_one_line_and_keeps_what_was_stored(cluster, empty_cache, tmp_path):
    """SIGKILL the scheduler while a worker measures a point: the sweep exits 1 within
    a bounded time, says the scheduler was lost in one line per point with no
    traceback, and every point it stored is whole (a local rerun completes the rest)."""
    from volcaustics.reports.measuring.results.store import Store

    address, _, _, _, scheduler = cluster
    spec = tmp_path / "sweep.toml"
    spec.write_text(SPEC)
    out = tmp_path / "store"
    sweep = _sweep_process(spec, out, address)
    assert _wait_until_busy(address, sweep, "point"), "the sweep ended before a worker took a point"
    scheduler.kill()
    output, _ = sweep.communicate(timeout=300)
    assert sweep.returncode == 1, output
    assert "Traceback" not in output, output
    failed = [line for line in output.splitlines() if "failed:" in line]
    assert failed and all("lost with the scheduler" in line for line in failed), output
    store = Store(str(out))
    points = [p.name for p in (out / "points").iterdir()] if (out / "points").exists() else []
    assert all(store.status(key) == "done" for key in points), output
    assert main(["sweep", str(spec), "-o", str(out), "--quiet"]) == 0  # nothing lost: the rest measured here
    assert len(list((out / "points").iterdir())) == 6
