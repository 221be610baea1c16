"""Choose the libLLVM that Dr.Jit's LLVM backend loads — before drjit is imported.

Dr.Jit needs libLLVM >= 16; Debian bookworm's stock libLLVM 14/15 crash inside
the JIT ("Cannot select: fminimum"). When ``DRJIT_LIBLLVM_PATH`` is unset we set
it to the newest ``libLLVM`` of major version >= 16 found in the usual library
folders. Mesa's own libLLVM 15 (used by llvmpipe) coexists in the same process.
"""

from __future__ import annotations

import glob
import os
import re
import sys
import warnings

MIN_MAJOR = 16
SEARCH_GLOBS = (
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so*",
    "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM*.so*",
    "/usr/lib/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
)
_VERSION = re.compile(r"libLLVM(?:-(\d+)[^/]*\.so.*|\.so\.(\d+).*)$")


def libllvm_major(path: str) -> int | None:
    """Major version read from a libLLVM file name (``libLLVM-19.so``, ``libLLVM.so.19.1``)."""
    m = _VERSION.search(os.path.basename(path))
    if not m:
        return None
    return int(m.group(1) or m.group(2))


def find_libllvm() -> str | None:
    """Newest libLLVM with major >= 16 on this machine, or None."""
    best = None
    for pattern in SEARCH_GLOBS:
        for path in sorted(glob.glob(pattern)):
            major = libllvm_major(path)
            if major is None or major < MIN_MAJOR or not os.path.isfile(path):
                continue
            if best is None or major > best[0]:
                best = (major, path)
    return None if best is None else best[1]


def ensure_libllvm() -> tuple[str | None, str]:
    """Set ``DRJIT_LIBLLVM_PATH`` if unset. Returns (path, how) where how is
    ``"environment"``, ``"chosen automatically"`` or ``"none found"``."""
    current = os.environ.get("DRJIT_LIBLLVM_PATH")
    if current:
        return current, "environment"
    path = find_libllvm()
    if path is None:
        return None, "none found"
    if "drjit" in sys.modules:
        warnings.warn("drjit was imported before volcaustics chose libLLVM; "
                      f"set DRJIT_LIBLLVM_PATH={path} yourself", RuntimeWarning, stacklevel=2)
    os.environ["DRJIT_LIBLLVM_PATH"] = path
    return path, "chosen automatically"
