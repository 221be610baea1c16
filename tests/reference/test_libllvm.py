"""libLLVM selection for Dr.Jit, variant probing and `volcaustics doctor`."""

from __future__ import annotations

import glob
import os
import re
import subprocess
import sys

import pytest

from volcaustics.reference.llvm import MIN_MAJOR, find_libllvm, libllvm_major
from volcaustics.reference.variant import probe


@pytest.mark.parametrize("name,major", [
    ("libLLVM-19.so", 19), ("libLLVM.so.19.1", 19), ("libLLVM-17.0.6.so", 17), ("libLLVM-14.so.1", 14),
    ("libLLVMSupport.a", None),
])
def test_major_from_file_name(name, major):
    assert libllvm_major("/usr/lib/" + name) == major


def test_chosen_libllvm_is_new_enough():
    path = os.environ["DRJIT_LIBLLVM_PATH"]  # set by `import reference` in conftest when unset
    assert os.path.isfile(path) and libllvm_major(path) >= MIN_MAJOR
    found = find_libllvm()
    assert found is not None and libllvm_major(found) >= MIN_MAJOR


def test_llvm_variant_renders():
    ok, detail, _ = probe("llvm_ad_rgb")
    assert ok, detail


OLD_LLVM = sorted(p for p in glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM-1[45].so") if os.path.isfile(p))


def _doctor(env_extra):
    exe = os.path.join(os.path.dirname(sys.executable), "volcaustics")
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    env.update(env_extra)
    return subprocess.run([exe, "doctor"], capture_output=True, text=True, env=env, timeout=300)


def test_doctor_passes_here():
    proc = _doctor({})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert re.search(r"variant llvm_ad_rgb\s+renders", proc.stdout) and "opengl" in proc.stdout
    # scalar_rgb renders Mitsuba's own integrators, not the reference's: the doctor says so
    scalar = next(line for line in proc.stdout.splitlines() if "variant scalar_rgb" in line)
    assert "not usable for the reference" in scalar


@pytest.mark.skipif(not OLD_LLVM, reason="no stock libLLVM 14/15 on this machine to demonstrate the crash")
def test_doctor_fails_with_stock_libllvm_and_says_the_fix():
    proc = _doctor({"DRJIT_LIBLLVM_PATH": OLD_LLVM[-1]})
    assert proc.returncode == 2
    assert "FAIL libllvm" in proc.stdout and "apt-get install libllvm19" in proc.stdout


@pytest.mark.parametrize("value, fragment", [("scalar_rgb", "expected one of"), ("no_such", "expected one of"),
                                             ("cuda_ad_rgb", "does not render here")])
def test_doctor_fails_on_a_variant_the_commands_refuse(value, fragment):
    """Every rendering command exits 2 on these; doctor said "the harness can run here"
   . cuda_ad_rgb is a case only where no GPU renders."""
    proc = _doctor({"VOLCAUSTICS_MI_VARIANT": value})
    if value == "cuda_ad_rgb" and re.search(r"variant cuda_ad_rgb\s+renders", proc.stdout):
        pytest.skip("cuda_ad_rgb renders here")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    line = next(line for line in proc.stdout.splitlines() if "VOLCAUSTICS_MI_VARIANT" in line)
    assert line.startswith("FAIL") and fragment in proc.stdout
