"""Interrupts that reach other threads.

A terminal's Ctrl-C and ``kill`` are process-directed: the kernel hands them to any
thread (Dr.Jit's, llvmpipe's, an executor's). Here a real signal is sent to a bystander
thread with ``pthread_kill`` at a chosen moment of a set's commit — its manifest's
removal and every rename — in a fresh interpreter; the set must end whole and new, and
the signal still end the process right after it. Blocking SIGINT in the main thread only
(the old ``sigint_held``) failed this at every rename, and SIGTERM was not held at all.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from tests.shared import FAST_MEASUREMENT, SINGLE_SCATTERING

# Runs BODY; at step AT of the commits into FOLDER (a commit's steps: 1 the manifest's
# removal, 2..5 the renames) sends SIGNAL to a sleeping bystander thread, then gives the
# main thread time to run its handlers before the step is done.
INJECT = """
import os, signal, sys, threading, time
folder, at, name = sys.argv[1], int(sys.argv[2]), sys.argv[3]
signal.signal(signal.SIGINT, signal.default_int_handler)  # as at a terminal (CI may start us with it ignored)
signal.signal(signal.SIGTERM, signal.SIG_DFL)
bystander = threading.Thread(target=time.sleep, args=(120,), daemon=True)
bystander.start()
steps = [0]

def tripping(real):
    def step(*args, **kwargs):
        target = str(args[-1])  # a step of a commit in the output folder: onto or removing a final name
        counts = target.startswith(folder) and not os.path.basename(target).startswith(".")
        steps[0] += counts
        if counts and steps[0] == at:
            signal.pthread_kill(bystander.ident, getattr(signal, name))
            time.sleep(0.1)  # the main thread runs pending handlers on its next bytecode
        return real(*args, **kwargs)
    return step

{body}
"""
SET_BODY = """
from volcaustics.infra.storage import atomic_set
paths = [os.path.join(folder, n) for n in ("a.bin", "b.bin", "c.bin", "manifest.json")]
with atomic_set(paths) as temps:
    for tmp in temps:
        open(tmp, "w").write("new")
    os.unlink, os.replace = tripping(os.unlink), tripping(os.replace)
print("the signal was lost")
"""
SET_FILES = ("a.bin", "b.bin", "c.bin", "manifest.json")


def _inject(tmp_path, body: str, at: int, name: str, *args) -> subprocess.CompletedProcess:
    script = tmp_path / "inject.py"
    script.write_text(INJECT.format(body=body))
    return subprocess.run([sys.executable, str(script), str(tmp_path / "out"), str(at), name, *args],
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("at", [1, 2, 3, 4, 5])
def test_a_signal_at_any_step_of_a_commit_waits_for_the_whole_set(tmp_path, at, name):
    out = tmp_path / "out"
    out.mkdir()
    for file in SET_FILES:
        (out / file).write_text("old")
    result = _inject(tmp_path, SET_BODY, at, name)
    contents = {p.name: p.read_text() for p in out.iterdir()}
    assert contents == {file: "new" for file in SET_FILES}, (contents, result.stderr[-2000:])
    assert result.returncode == -getattr(signal, name), result.stderr[-2000:]  # delivered after the set
    assert "the signal was lost" not in result.stdout


def test_a_signal_while_a_set_is_written_keeps_the_old_set_and_leaves_no_temporary(tmp_path):
    """SIGTERM (a CI job cancelled, ``kill``) while the command writes its set: the
    command line turns it into an interrupt (exit 143) so the temporaries go and the
    previous set stays; before, the process died where it stood and left hidden files."""
    out = tmp_path / "out"
    out.mkdir()
    for file in SET_FILES:
        (out / file).write_text("old")
    body = """
import volcaustics.reports.cli.doctor as doctor
from volcaustics.reports.cli import main
from volcaustics.infra.storage import atomic_set

def writing(args):
    with atomic_set([os.path.join(folder, n) for n in ("a.bin", "b.bin", "c.bin", "manifest.json")]) as temps:
        open(temps[0], "w").write("new")
        os.kill(os.getpid(), getattr(signal, name))
        time.sleep(5)
        open(temps[1], "w").write("new")
    return 0

doctor.run = writing
sys.exit(main(["doctor"]))
"""
    result = _inject(tmp_path, body, 0, "SIGTERM")
    assert result.returncode == 143, result.stderr[-2000:]
    assert "interrupted" in result.stderr and "Traceback" not in result.stderr
    assert {p.name: p.read_text() for p in out.iterdir()} == {file: "old" for file in SET_FILES}


@pytest.mark.parametrize("name,code", [("SIGINT", 130), ("SIGTERM", 143)])
def test_a_native_call_that_never_returns_is_stopped_at_once(tmp_path, name, code):
    """A native call holds Python's handlers until it returns: a Mitsuba render that hung
    (fov_y 1e-30) could not be stopped by Ctrl-C. Run where an interrupt does not wait
    for it (``interruptible``), the command ends at once with its exit code, and the
    process does not wait for the abandoned call at shutdown."""
    body = """
import volcaustics.reports.cli.doctor as doctor
from volcaustics.reports.cli import main
from volcaustics.infra.interrupts import interruptible

def hanging(args):
    threading.Timer(0.5, lambda: os.kill(os.getpid(), getattr(signal, name))).start()
    interruptible(time.sleep, 600)  # releases the GIL and never returns to Python, as a render does
    return 0

doctor.run = hanging
sys.exit(main(["doctor"]))
"""
    start = time.monotonic()
    result = _inject(tmp_path, body, 0, name)
    assert result.returncode == code, result.stderr[-2000:]
    assert time.monotonic() - start < 60  # the sleep is 600 s: it was not waited for
    assert "interrupted" in result.stderr and "Traceback" not in result.stderr


def test_temporaries_of_killed_processes_go_with_the_next_write_in_their_folder(tmp_path):
    """SIGKILL runs no ``finally``: the killed run's hidden temporaries stayed for ever.
    The next write into that folder removes those whose process is gone, and only those."""
    from volcaustics.infra.storage import atomic_write_text, owner

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    host = owner().rsplit("-", 1)[0]
    stale = tmp_path / f".summary.{host}-{dead.pid}-abcd1234.tmp.json"
    running = tmp_path / f".summary.{host}-{os.getpid()}-abcd1234.tmp.json"
    elsewhere = tmp_path / f".summary.otherhost-{dead.pid}-abcd1234.tmp.json"
    for path in (stale, running, elsewhere):
        path.write_text("half")
    atomic_write_text(str(tmp_path / "summary.json"), "{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([running.name, elsewhere.name, "summary.json"])


def test_a_killed_command_leaves_no_temporary_after_the_next_run(tmp_path):
    """The real thing: ``approx`` SIGKILLed while it writes its set leaves hidden files;
    the next ``approx`` into the same folder leaves only its set."""
    out = tmp_path / "out"
    body = """
from volcaustics.reports.cli import main
os.replace = tripping(os.replace)
sys.exit(main(sys.argv[4:]))
"""
    argv = ["approx", "refocus", "--preset", "quick", "--width", "16", "--height", "16", "-o", str(out / "shot.exr")]
    env_cache = {"VOLCAUSTICS_CACHE": str(tmp_path / "cache")}
    os.environ.update(env_cache)
    try:
        killed = _inject(tmp_path, body, 2, "SIGKILL", *argv)
        assert killed.returncode == -signal.SIGKILL
        assert any(p.name.startswith(".") for p in out.iterdir())  # what the killed run left
        again = _inject(tmp_path, body, 0, "SIGINT", *argv)
        assert again.returncode == 0, again.stderr[-2000:]
    finally:
        for key in env_cache:
            os.environ.pop(key)
    assert sorted(p.name for p in out.iterdir()) == ["shot.exr", "shot.json", "shot.png", "shot.records.npz"]


@pytest.mark.slow  # 20 runs of approx, ~50 s
@pytest.mark.parametrize("name,code", [("SIGINT", 130), ("SIGTERM", 143)])
@pytest.mark.parametrize("at", [1, 2, 3, 4, 5])
def test_approx_interrupted_at_any_step_of_its_commit_leaves_its_new_set(tmp_path, at, name, code):
    """The command itself (``approx``'s four outputs and its manifest): a signal to
    another thread at every step of the commit ends the run with its exit code after the
    new set is whole."""
    out = tmp_path / "out"
    argv = ["approx", "refocus", "--preset", "quick", "--width", "16", "--height", "16", "-o", str(out / "shot.exr")]
    body = """
from volcaustics.reports.cli import main
from volcaustics.infra import storage
storage.remove_file, os.replace = tripping(storage.remove_file), tripping(os.replace)
sys.exit(main(sys.argv[4:]))
"""
    os.environ["VOLCAUSTICS_CACHE"] = str(tmp_path / "cache")
    try:
        first = _inject(tmp_path, body, 0, name, *argv, "--seed", "1")
        assert first.returncode == 0, first.stderr[-2000:]
        old = max(p.stat().st_mtime_ns for p in out.iterdir())
        result = _inject(tmp_path, body, at, name, *argv, "--seed", "2")
    finally:
        os.environ.pop("VOLCAUSTICS_CACHE")
    assert result.returncode == code, result.stderr[-2000:]
    files = sorted(out.iterdir())
    assert [p.name for p in files] == ["shot.exr", "shot.json", "shot.png", "shot.records.npz"]
    assert all(p.stat().st_mtime_ns > old for p in files)  # all of the new run (seconds later)
    assert '"seed": 2' in (out / "shot.json").read_text()


MEASURE = ["measure", "refocus", "--preset", "quick", "--width", "32", "--height", "32", "--photon-res", "64",
           "--light-res", "64", "--seeds", "2", "--photons", "65536", "--spp", "8", "--batches", "4",
           "--target-noise", "none", "--quiet", *SINGLE_SCATTERING, *FAST_MEASUREMENT]


@pytest.mark.slow  # three tiny measurements, ~50 s
@pytest.mark.parametrize("at,name,code", [(3, "SIGINT", 130), (8, "SIGTERM", 143)])
def test_measure_interrupted_in_its_commit_leaves_its_new_set(tmp_path, at, name, code):
    """The issue's case: ``measure`` with Ctrl-C at the third step of its commit (2 of 2
    tries destroyed the previous set), and SIGTERM at its last (the manifest)."""
    out = tmp_path / "out"
    body = """
from volcaustics.reports.cli import main
from volcaustics.infra import storage
storage.remove_file, os.replace = tripping(storage.remove_file), tripping(os.replace)
sys.exit(main(sys.argv[4:]))
"""
    os.environ["VOLCAUSTICS_CACHE"] = str(tmp_path / "cache")
    try:
        first = _inject(tmp_path, body, 0, name, *MEASURE, "-o", str(out), "--seed", "1")
        assert first.returncode == 0, first.stderr[-2000:]
        old = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
        result = _inject(tmp_path, body, at, name, *MEASURE, "-o", str(out), "--seed", "2")
    finally:
        os.environ.pop("VOLCAUSTICS_CACHE")
    assert result.returncode == code, result.stderr[-2000:]
    new = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert set(new) == set(old) and len(new) >= at  # the same set, no temporary; the step was in it
    assert all(new[n] > max(old.values()) for n in new)  # all of the new run
