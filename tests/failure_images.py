"""What a failing image test leaves behind (STYLE.md item 7): the images it compared,
as one multi-layer EXR and tonemapped PNGs with a shared exposure, plus what it
measured, under ``test-output/<test>/`` (ignored by git; ``VOLCAUSTICS_TEST_OUTPUT``
moves it)."""

from __future__ import annotations

import json
import os
import re

import numpy as np

from volcaustics.infra.imageio import auto_exposure, write_exr, write_png

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def output_dir(test_name: str) -> str:
    """``test-output/<test_name>`` (characters outside [A-Za-z0-9._-] become ``_``), created."""
    base = os.environ.get("VOLCAUSTICS_TEST_OUTPUT") or os.path.join(ROOT, "test-output")
    folder = os.path.join(base, re.sub(r"[^A-Za-z0-9._-]+", "_", test_name).strip("_"))
    os.makedirs(folder, exist_ok=True)
    return folder


def write_compared_images(test_name: str, layers: dict, *, info: dict | None = None,
                          exposure_from: str | None = None, own_exposure: tuple = ()) -> str:
    """Write ``layers`` (name → H×W×3 or H×W float array, linear) to
    ``test-output/<test_name>/compared.exr``, one PNG per H×W×3 layer (the exposure of
    ``exposure_from`` except for the layers in ``own_exposure``, which get their own;
    negative values are written as their magnitude) and ``info.json``; returns the folder."""
    folder = output_dir(test_name)
    write_exr(os.path.join(folder, "compared.exr"), {k: np.asarray(v, np.float32) for k, v in layers.items()})
    exposure = auto_exposure(np.abs(layers[exposure_from])) if exposure_from else None
    for name, image in layers.items():
        image = np.abs(np.asarray(image, np.float32))
        if image.ndim == 3 and image.shape[2] == 3:
            write_png(os.path.join(folder, f"{name}.png"), image, None if name in own_exposure else exposure)
    if info is not None:
        with open(os.path.join(folder, "info.json"), "w", encoding="utf-8") as fh:
            json.dump(info, fh, indent=2, default=lambda x: np.asarray(x).tolist())
    return folder
