"""Ctrl-C during start-up: a real, process-directed
SIGINT sent from another thread while a native extension (Dr.Jit, Mitsuba, moderngl) or a
command module is being imported must end the run with exit 130 and one line, never a
traceback (it surfaced as NameError('_drjit_ext'), ImportError or SystemError) or an
aborted interpreter (exit 134)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
# Runs the CLI in a fresh interpreter; when TARGET starts importing, a thread waits DELAY s
# (into the module's initialisation) and sends SIGINT to the whole process.
TRIP = """
import importlib.abc, os, signal, sys, threading, time
target, delay = sys.argv[1], float(sys.argv[2])
signal.signal(signal.SIGINT, signal.default_int_handler)  # as at a terminal (CI may start us with it ignored)

class Trip(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target_module=None):
        if name == target:
            sys.meta_path.remove(self)
            threading.Thread(target=lambda: (time.sleep(delay), os.kill(os.getpid(), signal.SIGINT)),
                             daemon=True).start()
        return None

sys.meta_path.insert(0, Trip())
from volcaustics.reports.cli import main
sys.exit(main(sys.argv[3:]))
"""
REFERENCE = ["reference", "refocus", "--photons", "4096", "--spp", "2", "--batches", "2", "--width", "16",
             "--height", "16", "--force"]
APPROX = ["approx", "refocus", "--preset", "quick", "--width", "16", "--height", "16"]


@pytest.mark.parametrize("target, delay, argv", [
    ("drjit", 0.01, REFERENCE), ("drjit", 0.06, REFERENCE), ("mitsuba", 0.1, REFERENCE),
    ("moderngl", 0.01, APPROX), ("volcaustics.reports.cli.measure", 0.0, REFERENCE),
])
def test_ctrl_c_while_starting_exits_130_with_one_line(tmp_path, target, delay, argv):
    env = dict(os.environ, VOLCAUSTICS_CACHE=str(tmp_path / "cache"), VOLCAUSTICS_MI_VARIANT="llvm_ad_rgb")
    out = tmp_path / "out.exr"
    run = subprocess.run([sys.executable, "-c", TRIP, target, str(delay), *argv, "-o", str(out)], cwd=REPO, env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 130, run.stderr[-3000:]
    assert run.stderr.strip().splitlines()[-1] == "volcaustics: interrupted"
    assert "Traceback" not in run.stderr and "Fatal" not in run.stderr
    assert not out.exists()


DROPPED = """
import sys
import volcaustics.reports.cli.doctor as doctor
from volcaustics.reports.cli import main

class Finalised:
    def __del__(self):
        raise KeyboardInterrupt  # as a SIGINT landing in a finalizer or importlib's lock callback

def run(args):
    Finalised()  # dropped at once: Python ignores the interrupt and prints "Exception ignored in"
    return 0

doctor.run = run
sys.exit(main(["doctor"]))
"""


def test_an_interrupt_python_drops_in_a_finalizer_still_ends_the_run_with_one_line():
    """Ctrl-C that lands in a finalizer or a weakref callback (importlib's module locks, as
    the Mitsuba case above once showed) is dropped by Python with "Exception ignored in"
    and a traceback; the run records it and ends with exit 130 and one line."""
    run = subprocess.run([sys.executable, "-c", DROPPED], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert run.returncode == 130, run.stderr[-3000:]
    assert run.stderr.strip().splitlines() == ["volcaustics: interrupted"], run.stderr[-3000:]
