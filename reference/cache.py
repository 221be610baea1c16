"""On-disk cache of reference renders.

Key: SHA-256 of a JSON document of everything that determines the image
(:func:`key_document`): the scene exactly as Mitsuba gets it
(``reference.description``: medium box, meshes by the hash of their PLY bytes,
normals included, transforms as plain data), the scene model the integrators
read (its canonical form, camera at the image size), the resolved settings, the
light tracer's mode, the integrator code (a hash of its sources) and the Mitsuba
and Dr.Jit versions and variant. Computing it imports no Mitsuba. A result is an
EXR (mean and variance layers) plus a manifest JSON written after it; the
manifest records the EXR's SHA-256, so a truncated or mismatching file is
detected and re-rendered, never trusted.
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from volcaustics.scenes.canonical import canonical_dict
from volcaustics.scenes.imageio import read_exr, write_exr
from volcaustics.scenes.sources import source_hash
from volcaustics.scenes.storage import (
    atomic_path,
    atomic_write_bytes,
    atomic_write_text,
    cache_dir,
    cache_path,
    file_sha256,
)

from . import mi_setup

KEY_FORMAT = "volcaustics-reference-key/3"
# The code that turns a description into pixels is the folder reference/render/ (the
# integrators, their shape table, the conversion to Mitsuba objects, the batches and
# their seeds); the exporter's *output* is in the key itself. What finds, reads and
# writes entries (this module) lies outside it and changes no key.
RENDER_FOLDER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "render")


def code_version() -> str:
    """Hash of the sources under reference/render/ (``scenes.sources.source_hash``)."""
    return source_hash({"reference/render": RENDER_FOLDER})


def key_document(request, variant: str) -> dict:
    """What the key of a resolved :class:`reference.request.RenderRequest` rendered
    with Mitsuba ``variant`` hashes."""
    return {
        "format": KEY_FORMAT,
        "mitsuba_scene": request.description.tree,
        "scene": canonical_dict(request.scene),
        "settings": request.settings.batch_identity(),
        "mode": request.mode,
        "code": code_version(),
        "mitsuba": {**mi_setup.library_versions(), "variant": variant},
    }


def request_key(request, variant: str) -> str:
    """Key of a resolved request rendered with ``variant``."""
    text = json.dumps(key_document(request, variant), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def cache_key(scene, settings=None, *, mode: str = "caustic", variant: str | None = None) -> str:
    """Key of the reference of ``scene`` with ``settings`` (resolved here, see
    reference.request) and ``mode``, rendered with ``variant`` (default: the one this
    process renders with)."""
    from .request import resolve

    return request_key(resolve(scene, settings, mode), variant or mi_setup.render_variant())


def lookup(request):
    """(key, manifest) of a complete cache entry for ``request`` rendered with one of
    the variants this process serves (mi_setup.served_variants, in order), else None."""
    for variant in mi_setup.served_variants():
        key = request_key(request, variant)
        manifest = load(key)
        if manifest is not None:
            return key, manifest
    return None


def paths(key: str, *, write: bool = False) -> tuple[str, str]:
    """(EXR, manifest) paths of a cache entry; the PNG preview sits beside as <key>.png.
    To ``write``, the folder is made and must be writable (CacheError); to read, a
    read-only cache serves what it holds."""
    folder = cache_dir("reference") if write else cache_path("reference")
    return os.path.join(folder, f"{key}.exr"), os.path.join(folder, f"{key}.json")


def load(key: str):
    """The manifest if a complete, matching entry exists (EXR hash checked), else None."""
    from volcaustics.scenes.storage import read_json_object

    exr, manifest_path = paths(key)
    try:
        manifest = read_json_object(manifest_path)  # `null` or a list is a damaged entry, like torn JSON
        if manifest.get("key") != key or manifest.get("exr_sha256") != file_sha256(exr):
            return None
        if not os.path.exists(exr[:-4] + ".png"):
            return None
        return manifest
    except (OSError, ValueError, KeyError):
        return None


def store(key: str, layers: dict, manifest: dict, header: dict, png: bytes, state: dict | None = None) -> dict:
    """Write EXR, PNG preview and the batch state (``state``: arrays of float64 batch
    sums, to continue the render; ``<key>.npz``), then the manifest (the commit marker)."""
    exr, manifest_path = paths(key, write=True)
    write_exr(exr, layers, {**header, "volcaustics_reference_key": key})
    atomic_write_bytes(exr[:-4] + ".png", png)
    manifest = {**manifest, "key": key, "exr_sha256": file_sha256(exr)}
    if state is not None:
        with atomic_path(state_path(key)) as tmp:
            np.savez(tmp, **state)
        manifest["state_sha256"] = file_sha256(state_path(key))
    atomic_write_text(manifest_path, json.dumps(manifest, indent=2, default=float))
    return manifest


def state_path(key: str) -> str:
    """The batch state of a cache entry (float64 sums per stream, see reference.batches)."""
    return paths(key)[0][:-4] + ".npz"


def read_state(key: str, manifest: dict) -> dict | None:
    """The entry's batch state if present and matching its manifest, else None."""
    path = state_path(key)
    try:
        if manifest.get("state_sha256") != file_sha256(path):
            return None
        with np.load(path) as data:
            return {name: data[name] for name in data.files}
    except (OSError, ValueError, KeyError):
        return None


def read_layers(key: str) -> dict:
    return read_exr(paths(key)[0])[0]


class ReferenceResult:
    """A cached reference: ``manifest`` (photons, batches, seed, wall time, variant,
    versions, the caller's scene name and hash, settings, cached), ``exr_path``/``png_path`` of the cache
    files, and the images, read on first use: ``mean`` (layer → H×W×3 float32;
    mask_specular 0/1) and ``var`` (layer → variance of the mean)."""

    def __init__(self, key: str, manifest: dict, cached: bool, layers: dict | None = None):
        self.key, self.manifest, self.cached = key, {**manifest, "cached": cached}, cached
        self.exr_path, _ = paths(key)
        self.png_path = self.exr_path[:-4] + ".png"
        self._layers = layers

    def _load(self) -> dict:
        if self._layers is None:
            self._layers = read_layers(self.key)
        return self._layers

    @property
    def mean(self) -> dict:
        return {k: v for k, v in self._load().items() if not k.endswith("_var")}

    @property
    def var(self) -> dict:
        return {k[:-4]: v for k, v in self._load().items() if k.endswith("_var")}


def for_caller(manifest: dict, scene) -> dict:
    """A cached manifest with the caller's scene name and hash: one entry serves every
    scene that renders the same (other labels, another camera size with settings naming
    the size), and the caller is told about the scene it passed."""
    return {**manifest, "scene": scene.name, "scene_hash": scene.scene_hash()}


def cached_reference(key: str, scene) -> ReferenceResult | None:
    """The complete cache entry ``key`` (EXR hash checked) as a result for ``scene``,
    or None if this cache does not hold it (a sweep's workers use exactly the reference
    the sweep resolved)."""
    manifest = load(key)
    return None if manifest is None else ReferenceResult(key, for_caller(manifest, scene), cached=True)


def existing_reference(scene, settings=None, *, mode: str = "caustic") -> ReferenceResult | None:
    """The cache entry for ``scene`` and ``settings`` as it is (whatever its batches or
    floors, never continued), or None when there is none."""
    from .request import resolve

    served = lookup(resolve(scene, settings, mode))
    if served is None:
        return None
    key, manifest = served
    return ReferenceResult(key, for_caller(manifest, scene), cached=True)
