"""Code versions: a hash of the sources under whole folders, so that the boundary of
what changes a cached result is visible in the layout (a file moved within a folder
or added to it changes the hash; code outside the folders never does)."""

from __future__ import annotations

import hashlib
import os
from functools import lru_cache

SOURCE_SUFFIXES = (".py", ".glsl")


@lru_cache(maxsize=None)
def _folder_files(folder: str) -> tuple:
    files = []
    for parent, dirs, names in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        files.extend(os.path.join(parent, n) for n in names if n.endswith(SOURCE_SUFFIXES))
    return tuple(sorted(files))


def source_hash(folders: dict) -> str:
    """SHA-256 (16 hex digits) of the Python and GLSL files under each folder.

    ``folders`` maps a label (the folder as the repository names it, e.g.
    ``"reference/render"``) to its path; each file enters as its label-relative name
    and its bytes, in sorted order, so the hash does not depend on where the package
    is installed."""
    h = hashlib.sha256()
    for label in sorted(folders):
        root = folders[label]
        for path in _folder_files(root):
            h.update(f"{label}/{os.path.relpath(path, root)}".replace(os.sep, "/").encode())
            with open(path, "rb") as fh:
                h.update(fh.read())
    return h.hexdigest()[:16]
