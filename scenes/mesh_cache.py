"""Meshes as a scene asks for them: a :class:`~volcaustics.scenes.model.MeshSpec` read from its
file or built by its generator, placed in the world; generated meshes that take seconds
(marching cubes) cached as .npz under the cache folder."""

from __future__ import annotations

import functools
import hashlib
import os
from typing import Any, Protocol, cast

import numpy as np

from volcaustics.infra.storage import atomic_path, cache_dir, cache_path, note_not_cached, special_file_kind

from .generators import GENERATOR_VERSION, generate
from .mesh import Mesh, read_mesh_file


class MeshRequest(Protocol):
    """What a mesh is built from (``scenes.model.MeshSpec`` is one; hashable: the memory
    cache's key). Structural, so that the model imports this module and not the reverse."""

    @property
    def path(self) -> str | None: ...
    @property
    def generator(self) -> str | None: ...
    @property
    def params(self) -> tuple: ...
    @property
    def transform(self) -> Any: ...  # its matrix(): 4×4 object → world


# meshes kept in memory, by spec: a test worker or a sweep resolves scenes of more than 32
# meshes between two resolutions of one (the built-in and held-out scenes hold 22); at 32,
# Feline's 5 s mesh was built again seven times in one run of the closure tests
MESHES_KEPT = 256


@functools.lru_cache(maxsize=MESHES_KEPT)
def load_mesh_spec(spec: MeshRequest) -> Mesh:
    """World-space mesh for a :class:`scenes.model.MeshSpec` (cached by spec in
    memory; generated meshes also on disk, see :func:`generated_mesh`)."""
    if spec.path is not None:
        mesh = read_mesh_file(spec.path)
    else:
        mesh = generated_mesh(cast(str, spec.generator), spec.params)  # no path: the loader set a generator
    return mesh.transformed(spec.transform.matrix())


def generated_mesh(name: str, params: tuple) -> Mesh:
    """Object-space mesh of generator ``name``; big ones (marching cubes take
    seconds) are cached as .npz under the cache folder, keyed by generator,
    parameters and generator version. A damaged cache file is rebuilt
    (:func:`_read_cached_mesh`)."""
    key = hashlib.sha256(repr((name, GENERATOR_VERSION, tuple(params))).encode()).hexdigest()[:24]
    file = f"{name}-{key}.npz"
    cached = _read_cached_mesh(os.path.join(cache_path("meshes"), file), key)
    if cached is not None:
        return cached
    mesh = generate(name, dict(params))
    if len(mesh.faces) > 50_000:
        try:
            with atomic_path(os.path.join(cache_dir("meshes"), file)) as tmp:
                np.savez(tmp, vertices=mesh.vertices, faces=mesh.faces, key=np.asarray(key),
                         digest=np.asarray(_mesh_digest(mesh.vertices, mesh.faces)))
        except OSError as exc:  # a read-only cache (CacheError), a folder in the entry's place: built again next time
            note_not_cached(exc, "generated meshes")
    return mesh


def _mesh_digest(vertices: np.ndarray, faces: np.ndarray) -> str:
    """SHA-256 of a mesh's arrays (float64 N×3 vertices, int64 M×3 faces)."""
    return hashlib.sha256(np.ascontiguousarray(vertices, np.float64).tobytes()
                          + np.ascontiguousarray(faces, np.int64).tobytes()).hexdigest()


def _read_cached_mesh(path: str, key: str) -> Mesh | None:
    """The mesh of the generated-mesh cache file ``path`` if it is the entry ``key``
    and undamaged: its arrays match the digest stored with them, vertices N×3 finite,
    faces M×3 indexing them. Else None (regenerated): a damaged cache entry is never a
    mesh, nor an error about the scene file. Files from before the digest count as damaged."""
    import zipfile


    if special_file_kind(path):
        return None
    try:
        with np.load(path) as data:
            vertices, faces = np.asarray(data["vertices"]), np.asarray(data["faces"])
            stored_key, digest = str(data["key"]), str(data["digest"])
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
        return None
    shapes = vertices.ndim == 2 and vertices.shape[1:] == (3,) and faces.ndim == 2 and faces.shape[1:] == (3,)
    types = np.issubdtype(vertices.dtype, np.floating) and np.issubdtype(faces.dtype, np.integer)
    if stored_key != key or not shapes or not types or not np.isfinite(vertices).all() \
            or digest != _mesh_digest(vertices, faces):
        return None
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        return None
    return Mesh(vertices, faces)
