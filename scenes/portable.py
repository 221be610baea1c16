"""A scene that travels to a machine which shares no disk with this one: its mesh
files go with it as bytes, named by their SHA-256 (``MeshSpec.content_hash``), and are
written into that machine's cache, where the scene then finds them. The scene hash
follows the geometry, not where a file lies, so the scene there is the same scene.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os

from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import atomic_write_bytes, cache_dir, cache_path, file_sha256

from .model import Scene

SHIPPED_FOLDER = "shipped-meshes"  # the cache's folder of mesh files a scene brought with it


def packed(scene: Scene) -> tuple:
    """(``scene``, {content hash: (file extension, bytes)}) for every mesh file it names."""
    files = {}
    for spec in [o.mesh for o in scene.specular] + [o.mesh for o in scene.diffuse]:
        if spec.path is not None and spec.content_hash not in files:
            with open(spec.path, "rb") as fh:
                data = fh.read()
            if hashlib.sha256(data).hexdigest() != spec.content_hash:
                raise InputError(f"{spec.path}: changed since the scene {scene.name} was loaded; load it again")
            files[spec.content_hash] = (os.path.splitext(spec.path)[1].lower(), data)
    return scene, files


def unpacked(package: tuple) -> Scene:
    """The scene :func:`packed` gave, its mesh files written into this machine's cache
    (once: a file already there with those bytes is used as it is) and named there."""
    scene, files = package
    paths = {}
    for digest, (ext, data) in files.items():
        name = f"{digest}{ext}"
        path = cache_path(SHIPPED_FOLDER, name)
        if not _holds(path, digest):
            path = os.path.join(cache_dir(SHIPPED_FOLDER), name)
            atomic_write_bytes(path, data)
        paths[digest] = path

    def moved(obj):
        spec = obj.mesh
        if spec.path is None:
            return obj
        return dataclasses.replace(obj, mesh=dataclasses.replace(spec, path=paths[spec.content_hash]))

    return dataclasses.replace(scene, specular=tuple(moved(o) for o in scene.specular),
                               diffuse=tuple(moved(o) for o in scene.diffuse))



def _holds(path: str, digest: str) -> bool:
    try:
        return file_sha256(path) == digest
    except OSError:  # missing, or not a regular file
        return False
