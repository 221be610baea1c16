"""A read-only cache serves what it holds: `cache_dir` refused it up front
although nothing needed writing; now only a write is refused (exit 2, naming the folder
and the fix), and a reference render is refused before it starts, not after."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time

import pytest

from tests.shared import FAST_MEASUREMENT, SINGLE_SCATTERING
from volcaustics.reports.cli import main

TINY = ["--photons", "20000", "--spp", "2", "--batches", "2", "--height", "12"]
MEASURE = ["--photon-res", "8", "--light-res", "16", "--seeds", "1", "--quiet", "--target-noise", "none",
           *SINGLE_SCATTERING, *FAST_MEASUREMENT]


def _read_only_run(argv, env):
    """``volcaustics argv`` in a process that cannot write into read-only folders: root
    writes everywhere, so as root the process runs without CAP_DAC_OVERRIDE (capsh)."""
    command = [os.path.join(os.path.dirname(sys.executable), "volcaustics"), *argv]
    if os.geteuid() == 0:
        if not shutil.which("capsh"):
            pytest.skip("root writes into read-only folders and capsh is not here to stop it")
        command = ["capsh", "--drop=cap_dac_override,cap_dac_read_search", "--", "-c",
                   " ".join(f"'{a}'" for a in command)]
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=300)


def _make_read_only(folder):
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            os.chmod(os.path.join(root, name), 0o555 if name in dirs else 0o444)
    os.chmod(folder, 0o555)


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_read_only_cache_serves_its_entries_and_refuses_only_a_write(tmp_path, monkeypatch, capsys):
    cache = tmp_path / "cache"
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(cache))
    assert main(["reference", "sphere1", "-o", str(tmp_path / "r.exr"), "--width", "16", *TINY]) == 0
    assert main(["measure", "sphere1", "-o", str(tmp_path / "m"), "--width", "16", *TINY, *MEASURE]) == 0
    capsys.readouterr()
    _make_read_only(cache)
    env = {**os.environ, "VOLCAUSTICS_CACHE": str(cache), "VOLCAUSTICS_MI_VARIANT": "llvm_ad_rgb"}
    try:
        served = _read_only_run(["reference", "sphere1", "-o", str(tmp_path / "r2.exr"), "--width", "16", *TINY], env)
        assert served.returncode == 0, served.stderr
        measured = _read_only_run(["measure", "sphere1", "-o", str(tmp_path / "m2"), "--width", "16", *TINY,
                                   *MEASURE], env)
        assert measured.returncode == 0, measured.stderr
        assert "from the store" in measured.stdout  # the point measured above, read back
        other = _read_only_run(["measure", "sphere1", "-o", str(tmp_path / "m3"), "--width", "16", *TINY, *MEASURE,
                                "--seed", "7"], env)  # not in the store: refused before it is measured
        assert other.returncode == 2 and "result store" in other.stderr and "not a writable folder" in other.stderr
        assert not (tmp_path / "m3").exists() and "Traceback" not in other.stderr, other.stderr
        t0 = time.perf_counter()
        missing = _read_only_run(["reference", "sphere1", "-o", str(tmp_path / "r3.exr"), "--width", "24", *TINY],
                                 env)
        assert missing.returncode == 2 and "not a writable folder" in missing.stderr, missing.stderr
        assert str(cache / "reference") in missing.stderr and "VOLCAUSTICS_CACHE" in missing.stderr
        assert time.perf_counter() - t0 < 60  # refused before the render, not after it
        assert "Traceback" not in missing.stderr
    finally:
        for root, dirs, _ in os.walk(cache):
            for name in dirs:
                os.chmod(os.path.join(root, name), 0o755)
        os.chmod(cache, 0o755)
