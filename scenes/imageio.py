"""Multi-layer OpenEXR files (float32, ZIP), written atomically.

Used by every package (renders, reference cache, reports); lives with the
shared storage helpers at the bottom of the data flow.
"""

from __future__ import annotations

import numpy as np

from .storage import atomic_path


def write_exr(path: str, layers: dict, metadata: dict | None = None) -> None:
    """Write a multi-layer OpenEXR file atomically (ZIP compression, float32).

    layers: name → H×W×3 array (channels ``name.R/G/B``) or H×W array (``name.Y``);
    ``mask_specular`` is written as one ``.Y`` channel. metadata: name → str header attributes.
    """
    import OpenEXR

    channels = {}
    for name, image in layers.items():
        image = np.asarray(image, dtype=np.float32)
        if name == "mask_specular" and image.ndim == 3:
            image = image[..., 0]
        if image.ndim == 2:
            channels[f"{name}.Y"] = np.ascontiguousarray(image)
        elif image.ndim == 3 and image.shape[2] == 3:
            for k, c in enumerate("RGB"):
                channels[f"{name}.{c}"] = np.ascontiguousarray(image[..., k])
        else:
            raise ValueError(f"layer {name!r}: expected H×W or H×W×3, got shape {image.shape}")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for key, value in (metadata or {}).items():
        header[key] = str(value)
    with atomic_path(path) as tmp:
        with OpenEXR.File(header, channels) as f:
            f.write(tmp)


def read_exr(path: str) -> tuple[dict, dict]:
    """(layers, header) of a file written by :func:`write_exr`: layers are H×W×3
    float32 (``.Y`` layers broadcast to 3 channels)."""
    import OpenEXR

    with OpenEXR.File(path, separate_channels=True) as f:
        channels = {name: np.asarray(ch.pixels, dtype=np.float32) for name, ch in f.channels().items()}
        header = dict(f.header())
    layers = {}
    for name in sorted({c.rsplit(".", 1)[0] for c in channels}):
        if f"{name}.Y" in channels:
            layers[name] = np.repeat(channels[f"{name}.Y"][..., None], 3, axis=2)
        else:
            layers[name] = np.stack([channels[f"{name}.{c}"] for c in "RGB"], axis=-1)
    return layers, header
