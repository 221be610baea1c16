"""Ctrl-C while a sweep's references render on its worker processes: exit 130, the
reference not stored, no worker left, and no traceback. A batch cancelled while queued
made the local pool's manager thread raise InvalidStateError once the pool was killed
(seen on a Ctrl-C by hand; the sweep cannot make that race happen on demand, the pool
test below does)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

from volcaustics.reports.measuring.pools.executors import open_pool

SPEC = """
scenes = ["refocus"]
seeds = 1
[vary]
layers = [1, 2]
[set]
width = 32
height = 32
photon_res = 64
light_res = 64
[reference]
photons = 16777216
spp = 32
batches = 32
target_noise = "none"
max_scatter = 1
[measurement]
exact_subphotons = 1
"""


@pytest.mark.slow  # a fault injection: worker processes started, interrupted mid-render (about 5 s)
def test_ctrl_c_while_references_render_on_the_workers(empty_cache, tmp_path):
    spec = tmp_path / "sweep.toml"
    spec.write_text(SPEC)  # 64 batches of 2^19 photons: tens of seconds on two workers
    command = [sys.executable, "-m", "volcaustics", "sweep", str(spec), "-o", str(tmp_path / "store"),
               "--workers", "2", "--quiet"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=os.environ.copy(),
                               cwd=Path(__file__).resolve().parents[2], start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # a worker writes the scene's meshes into the cache when it loads the scene for its first batch
    deadline = time.time() + 120
    while time.time() < deadline and process.poll() is None and not (empty_cache / "mitsuba-meshes").exists():
        time.sleep(0.1)
    time.sleep(1.0)
    workers = psutil.Process(process.pid).children(recursive=True)
    assert process.poll() is None and workers, process.communicate()
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=120)
    err = err.decode()
    assert process.returncode == 130, err[-2000:]
    assert "interrupted" in err and "Traceback" not in err and "InvalidStateError" not in err, err[-2000:]
    assert not list((empty_cache / "reference").glob("*.json"))  # a reference is stored whole or not at all
    _, alive = psutil.wait_procs(workers, timeout=10)  # the resource tracker ends once the pool is gone
    assert not alive, [w.cmdline() for w in alive]


def test_a_local_pool_killed_after_dropping_queued_tasks_raises_nothing(monkeypatch):
    """One worker, six tasks: five wait in the pool's queue; dropping three of them and
    then Ctrl-C (the pool's workers killed) raised InvalidStateError in its manager
    thread when the drop cancelled them."""
    errors = []
    monkeypatch.setattr(threading, "excepthook", lambda args: errors.append(args.exc_type.__name__))
    with pytest.raises(KeyboardInterrupt):
        with open_pool(workers=1) as pool:
            futures = [pool.submit(time.sleep, 5) for _ in range(6)]
            time.sleep(1.0)
            pool.cancel(futures[3:])
            raise KeyboardInterrupt
    assert not errors
