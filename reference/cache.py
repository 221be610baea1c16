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

from scenes.canonical import canonical_dict
from scenes.imageio import read_exr, write_exr
from scenes.storage import atomic_path, atomic_write_bytes, atomic_write_text, cache_dir, file_sha256

from . import mi_setup

KEY_FORMAT = "volcaustics-reference-key/2"
# The code that turns a description into pixels. The exporter's *output* is in the
# key itself; export.py is here for its conversion of descriptions to Mitsuba objects.
_SOURCES = ("integrators.py", "render.py", "shapes.py", "export.py")


def code_version() -> str:
    here = os.path.dirname(os.path.abspath(__file__))
    h = hashlib.sha256()
    for name in _SOURCES:
        with open(os.path.join(here, name), "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:16]


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


def paths(key: str) -> tuple[str, str]:
    """(EXR, manifest) paths of a cache entry; the PNG preview sits beside as <key>.png."""
    folder = cache_dir("reference")
    return os.path.join(folder, f"{key}.exr"), os.path.join(folder, f"{key}.json")


def load(key: str):
    """The manifest if a complete, matching entry exists (EXR hash checked), else None."""
    from scenes.storage import read_json_object

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
    exr, manifest_path = paths(key)
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
