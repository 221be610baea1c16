"""What produced a result: the code version of the folders involved and the versions
of the libraries, for result keys and ``summary.json``."""

from __future__ import annotations

import importlib
import os
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version

from volcaustics.infra.sources import source_hash

# the folders an experiment's numbers depend on (the reference's own pixels have their key,
# reference.cache.code_version); as the repository names them
EXPERIMENT_FOLDERS = ("scenes", "approx", "reference", "metrics", "experiment")


def _folder(name: str) -> str:
    """The folder of ``name`` (repository spelling) wherever the packages are: the
    top-level folders are installed as volcaustics.<folder> (setup.py)."""
    top, _, rest = name.partition("/")
    package = importlib.import_module(f"volcaustics.{top}")
    folder = os.path.join(package.__path__[0], *rest.split("/")) if rest else package.__path__[0]
    if not os.path.isdir(folder):  # a folder moved away would hash nothing: a key blind to its code
        raise FileNotFoundError(f"code version of {name!r}: no folder {folder}")
    return folder


@lru_cache(maxsize=None)
def code_version(folders: tuple = EXPERIMENT_FOLDERS) -> str:
    """SHA-256 (16 hex digits) of the Python and GLSL sources under ``folders``."""
    return source_hash({name: _folder(name) for name in folders})


def library_versions() -> dict:
    """Versions of the libraries whose behaviour the numbers depend on."""
    out: dict[str, str | None] = {}
    for dist in ("volcaustics", "numpy", "mitsuba", "drjit", "moderngl", "flip-evaluator", "scikit-image",
                 "pandas", "pyarrow"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = None
    return out
