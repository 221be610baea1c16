"""On-disk cache of reference renders.

Key: SHA-256 of the canonical scene JSON, the resolved settings and the
reference code version (a hash of the integrator and export sources). A result
is an EXR (mean and variance layers) plus a manifest JSON written after it; the
manifest records the EXR's SHA-256, so a truncated or mismatching file is
detected and re-rendered, never trusted.
"""

from __future__ import annotations

import hashlib
import json
import os

from scenes.imageio import read_exr, write_exr
from scenes.storage import atomic_write_bytes, atomic_write_text, cache_dir, file_sha256

_SOURCES = ("integrators.py", "export.py", "render.py", "shapes.py")


def code_version() -> str:
    here = os.path.dirname(os.path.abspath(__file__))
    h = hashlib.sha256()
    for name in _SOURCES:
        with open(os.path.join(here, name), "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:16]


def cache_key(scene, settings=None) -> str:
    """Key of the reference of ``scene`` with ``settings`` (resolved here, see reference.request)."""
    from .request import resolve

    return request_key(resolve(scene, settings))


def request_key(request) -> str:
    """Key of a resolved :class:`reference.request.RenderRequest`."""
    text = json.dumps({"scene": request.scene.canonical_json(), "settings": request.settings.to_dict(),
                       "code": code_version()}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def paths(key: str) -> tuple[str, str]:
    """(EXR, manifest) paths of a cache entry; the PNG preview sits beside as <key>.png."""
    folder = cache_dir("reference")
    return os.path.join(folder, f"{key}.exr"), os.path.join(folder, f"{key}.json")


def load(key: str):
    """The manifest if a complete, matching entry exists (EXR hash checked), else None."""
    exr, manifest_path = paths(key)
    try:
        with open(manifest_path) as fh:
            manifest = json.load(fh)
        if manifest.get("key") != key or manifest.get("exr_sha256") != file_sha256(exr):
            return None
        if not os.path.exists(exr[:-4] + ".png"):
            return None
        return manifest
    except (OSError, ValueError, KeyError):
        return None


def store(key: str, layers: dict, manifest: dict, header: dict, png: bytes) -> dict:
    """Write EXR and PNG preview, then the manifest (the commit marker)."""
    exr, manifest_path = paths(key)
    write_exr(exr, layers, {**header, "volcaustics_reference_key": key})
    atomic_write_bytes(exr[:-4] + ".png", png)
    manifest = {**manifest, "key": key, "exr_sha256": file_sha256(exr)}
    atomic_write_text(manifest_path, json.dumps(manifest, indent=2, default=float))
    return manifest


def read_layers(key: str) -> dict:
    return read_exr(paths(key)[0])[0]
