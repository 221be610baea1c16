"""What produced a result: the code version of the packages involved and the
versions of the libraries and GL driver, for result keys and ``summary.json``."""

from __future__ import annotations

import hashlib
import os
from functools import lru_cache

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# what an experiment's numbers depend on (reference has its own, reference.cache.code_version)
EXPERIMENT_SOURCES = ("approx", "metrics", "scenes", "reference/oracle.py", "reports/exact.py",
                      "reports/experiment.py")


@lru_cache(maxsize=None)
def code_version(sources: tuple = EXPERIMENT_SOURCES) -> str:
    """SHA-256 (16 hex digits) of the Python and GLSL sources under ``sources``
    (folders or files relative to the repository), in sorted path order."""
    files = []
    for src in sources:
        path = os.path.join(_ROOT, src)
        if os.path.isfile(path):
            files.append(path)
            continue
        for folder, _, names in os.walk(path):
            files.extend(os.path.join(folder, n) for n in names if n.endswith((".py", ".glsl")))
    h = hashlib.sha256()
    for path in sorted(files):
        h.update(os.path.relpath(path, _ROOT).encode())
        with open(path, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:16]


def library_versions() -> dict:
    """Versions of the libraries whose behaviour the numbers depend on."""
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for dist in ("volcaustics", "numpy", "mitsuba", "drjit", "moderngl", "flip-evaluator", "scikit-image",
                 "colour-science", "pandas", "pyarrow"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = None
    return out
