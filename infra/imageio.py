"""Image files, written atomically: multi-layer OpenEXR (float32, ZIP) and
tonemapped sRGB PNG previews.

Used by every package (renders, reference cache, reports); lives with the
shared storage helpers at the bottom of the layers. The one layer written as a single
channel, ``mask_specular``, is named here (``MASK_LAYER``) and re-exported by
``scenes.formats`` with the other layer names. The sRGB encoding is the
IEC 61966-2-1 piecewise OETF in numpy (importing colour-science costs over a
second per command); the tests check it against colour-science's
``cctf_encoding(..., function="sRGB")``.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

from .storage import atomic_path, atomic_write_bytes

BEAUTY_LAYER = "combined"  # also written as the root R, G, B channels
MASK_LAYER = "mask_specular"  # H×W×3 float32, 1 where the camera sees glass, else 0: one .Y channel


def write_exr(path: str, layers: dict, metadata: dict | None = None) -> None:
    """Write a multi-layer OpenEXR file atomically (ZIP compression, float32).

    layers: name → H×W×3 array (channels ``name.R/G/B``) or H×W array (``name.Y``);
    ``mask_specular`` is written as one ``.Y`` channel. A ``combined`` layer is also
    written as the root ``R``, ``G``, ``B`` channels, so that viewers (tev, OpenEXR's
    exrdisplay) open on the beauty image, as Mitsuba's AOV films do. metadata: name →
    str header attributes.
    """
    import OpenEXR

    channels = {}
    for name, image in layers.items():
        image = np.asarray(image, dtype=np.float32)
        if name == MASK_LAYER and image.ndim == 3:
            image = image[..., 0]
        if image.ndim == 2:
            channels[f"{name}.Y"] = np.ascontiguousarray(image)
        elif image.ndim == 3 and image.shape[2] == 3:
            for k, c in enumerate("RGB"):
                channels[f"{name}.{c}"] = np.ascontiguousarray(image[..., k])
        else:
            raise ValueError(f"layer {name!r}: expected H×W or H×W×3, got shape {image.shape}")
        if name == BEAUTY_LAYER and image.ndim == 3:
            for k, c in enumerate("RGB"):
                channels[c] = np.ascontiguousarray(image[..., k])
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for key, value in (metadata or {}).items():
        header[key] = str(value)
    with atomic_path(path) as tmp:
        with OpenEXR.File(header, channels) as f:
            f.write(tmp)


def read_exr(path: str) -> tuple[dict, dict]:
    """(layers, header) of a file written by :func:`write_exr`: layers are H×W×3
    float32 (``.Y`` layers broadcast to 3 channels); the root channels (the beauty
    image's copy of ``combined``) are not a layer of their own."""
    import OpenEXR

    with OpenEXR.File(path, separate_channels=True) as f:
        channels = {name: np.asarray(ch.pixels, dtype=np.float32) for name, ch in f.channels().items()}
        header = dict(f.header())
    layers = {}
    for name in sorted({c.rsplit(".", 1)[0] for c in channels if "." in c}):
        if f"{name}.Y" in channels:
            layers[name] = np.repeat(channels[f"{name}.Y"][..., None], 3, axis=2)
        else:
            layers[name] = np.stack([channels[f"{name}.{c}"] for c in "RGB"], axis=-1)
    return layers, header


def auto_exposure(image: np.ndarray, percentile: float = 99.5) -> float:
    """Scale that maps the given percentile of luminance (of non-zero pixels) to 1."""
    lum = image[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    lum = lum[lum > 0]
    if lum.size == 0:
        return 1.0
    level = float(np.percentile(lum, percentile))
    return 1.0 / level if level > 0 else 1.0


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """sRGB OETF (IEC 61966-2-1) of linear values in [0, 1], float64."""
    x = np.asarray(linear, dtype=np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0.0031308), 1 / 2.4) - 0.055)


def tonemap_srgb8(image: np.ndarray, exposure: float | None = None) -> np.ndarray:
    """Linear H×W×3 float (≥ 0) → H×W×3 uint8 sRGB: exposure, clip to [0, 1], sRGB OETF.

    ``exposure`` None means :func:`auto_exposure`.
    """
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"expected an H×W×3 image, got shape {image.shape}")
    scale = auto_exposure(image) if exposure is None else exposure
    linear = np.clip(np.nan_to_num(image.astype(np.float64) * scale, nan=0.0, posinf=1.0), 0.0, 1.0)
    return np.round(srgb_encode(linear) * 255.0).astype(np.uint8)


def png_bytes(rgb8: np.ndarray) -> bytes:
    """PNG file bytes of an H×W×3 uint8 image (8-bit RGB, no filtering)."""
    if rgb8.dtype != np.uint8 or rgb8.ndim != 3 or rgb8.shape[2] != 3:
        raise ValueError(f"expected H×W×3 uint8, got {rgb8.dtype} {rgb8.shape}")
    h, w, _ = rgb8.shape
    raw = b"".join(b"\x00" + rgb8[row].tobytes() for row in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")


def write_png(path: str, image: np.ndarray, exposure: float | None = None) -> None:
    """Write a linear H×W×3 image as a tonemapped sRGB PNG (atomically)."""
    atomic_write_bytes(path, png_bytes(tonemap_srgb8(image, exposure)))

