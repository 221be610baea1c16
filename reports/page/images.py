"""Images of a report as PNG data URIs: renders at a stated exposure, error maps on
fixed, stated colour scales (``reports.core.scales``: :data:`SCALES`), and the colour
bars that go with them."""

from __future__ import annotations

import base64

import numpy as np

from volcaustics.reports.core.scales import SCALES, Scale, colormap_lut, heatmap_rgb8
from volcaustics.scenes.imageio import png_bytes, tonemap_srgb8

__all__ = ["SCALES", "Scale", "colour_bar_css", "data_uri", "heatmap_uri", "render_uri"]


def data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def render_uri(image: np.ndarray, exposure: float) -> str:
    """A linear H×W×3 image × ``exposure``, clipped, sRGB-encoded, as a PNG data URI."""
    return data_uri(png_bytes(tonemap_srgb8(np.asarray(image, np.float32), exposure=exposure)))


def heatmap_uri(values: np.ndarray, scale: Scale) -> str:
    """An H×W map (NaN: not compared) coloured on ``scale``, as a PNG data URI."""
    return data_uri(png_bytes(heatmap_rgb8(values, scale)))


def colour_bar_css(scale: Scale, stops: int = 9) -> str:
    """A CSS linear-gradient (left to right) of the scale's colour map."""
    lut = colormap_lut(scale.colormap, stops)
    parts = [f"rgb({r},{g},{b}) {100 * k / (stops - 1):.1f}%" for k, (r, g, b) in enumerate(lut)]
    return "linear-gradient(to right, " + ", ".join(parts) + ")"
