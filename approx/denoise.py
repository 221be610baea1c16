"""Denoising as a measured option (``denoise`` = oidn): Intel Open Image Denoise (its
Python binding ``pyoidn``, on the CPU) applied to a frame's caustic and fog layers,
with the G-buffer's albedo and normal as guides (the first surface's: a diffuse
surface's albedo, 1 on glass, 0 where nothing is hit; its world normal), and the
combined layer composed again. Its wall time and the pixels it filtered are reported
beside the frame cost, never inside it: the equal-cost comparison is made without it
and shown with it (docs/decisions.md "Denoising, measured beside").
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.scenes.formats import KIND_DIFFUSE, KIND_SPECULAR

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

DENOISED = ("caustic", "fog")  # the layers with photon or marching noise; direct is noise-free


def unavailable() -> str | None:
    """Why the binding cannot load here (None when it can)."""
    try:
        import pyoidn  # noqa: F401
    except (ImportError, OSError) as exc:
        return f"pyoidn (Intel Open Image Denoise) cannot load: {exc}"
    return None


def guides(scene: Scene, geometry: np.ndarray, normal: np.ndarray) -> tuple:
    """(albedo, normal), each H×W×3 float32 in OIDN's ranges, from the G-buffer's
    geometry (distance, kind, material) and world normal images."""
    kind = np.round(geometry[..., 1]).astype(int)
    material = np.round(geometry[..., 2]).astype(int)
    table = np.asarray([o.albedo for o in scene.diffuse] or [(0.0, 0.0, 0.0)], np.float32)
    albedo = np.zeros(geometry.shape[:2] + (3,), np.float32)
    diffuse = kind == KIND_DIFFUSE
    albedo[diffuse] = table[np.clip(material[diffuse], 0, len(table) - 1)]
    albedo[kind == KIND_SPECULAR] = 1.0
    return np.clip(albedo, 0.0, 1.0), np.clip(np.asarray(normal, np.float32), -1.0, 1.0)


def denoise_images(images: dict, albedo: np.ndarray, normal: np.ndarray) -> tuple:
    """(images with DENOISED layers filtered and ``combined`` recomposed, wall seconds,
    pixels filtered). RuntimeError naming the reason when the binding cannot load."""
    reason = unavailable()
    if reason:
        raise RuntimeError(f"denoise = oidn: {reason}; install it (pip install pyoidn) or use denoise = none")
    import pyoidn

    t0 = time.perf_counter()
    out = dict(images)
    for layer in DENOISED:
        colour = np.ascontiguousarray(np.maximum(images[layer], 0.0), np.float32)
        out[layer] = np.asarray(pyoidn.denoise(colour, albedo, normal, hdr=True), np.float32)
    out["combined"] = out["caustic"] + out["fog"] + out["direct"]
    pixels = len(DENOISED) * int(np.prod(images["caustic"].shape[:2]))
    return out, time.perf_counter() - t0, pixels
