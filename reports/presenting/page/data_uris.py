"""Images of a report as PNG data URIs: renders at a stated exposure, error maps on
fixed, stated colour scales (``reports.presenting.figures.scales``: :data:`SCALES`), and the colour
bars that go with them."""

from __future__ import annotations

import base64
from collections.abc import Collection, Mapping

import numpy as np

from volcaustics.infra.imageio import png_bytes, tonemap_srgb8
from volcaustics.metrics.image import reference_exposure
from volcaustics.reports.presenting.figures.scales import SCALES, Scale, colormap_lut, heatmap_rgb8

__all__ = ["SCALES", "SHOWN", "Scale", "colour_bar_css", "component_images", "data_uri", "exposures", "heatmap_uri",
           "render_uri"]

SHOWN = ("caustic", "combined")  # the components whose renders and error maps a page draws


def data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def render_uri(image: np.ndarray, exposure: float) -> str:
    """A linear H×W×3 image × ``exposure``, clipped, sRGB-encoded, as a PNG data URI."""
    return data_uri(png_bytes(tonemap_srgb8(np.asarray(image, np.float32), exposure=exposure)))


def heatmap_uri(values: np.ndarray, scale: Scale) -> str:
    """An H×W map (NaN: not compared) coloured on ``scale``, as a PNG data URI."""
    return data_uri(png_bytes(heatmap_rgb8(values, scale)))


def exposures(views: dict, components: Collection[str] = SHOWN) -> dict:
    """One exposure per shown component (of ``components``): the reference's bright
    pixels to 1 (``metrics.image.reference_exposure`` over the compared pixels), 1 for a
    black reference. ``views``: ``reference.<component>`` and ``compared`` (H×W or H×W×3)."""
    compared = np.asarray(views["compared"])
    keep = (compared[..., 0] if compared.ndim == 3 else compared) > 0.5
    out = {}
    for component in (c for c in SHOWN if c in components):
        try:
            out[component] = reference_exposure(views[f"reference.{component}"], mask=keep)
        except ValueError:  # a black reference
            out[component] = 1.0
    return out


def component_images(views: dict, exposure: Mapping, own: str) -> dict:
    """Data URIs of the renders and error maps of every component in ``exposure``: the
    renderer's (``own``: "approx", "renderer") and the reference's at that exposure, the
    maps on the fixed scales (None where the metric had no value)."""
    out: dict[str, str | None] = {}
    for component, scale_by in exposure.items():
        out[f"{own}.{component}"] = render_uri(views[f"{own}.{component}"], scale_by)
        out[f"reference.{component}"] = render_uri(views[f"reference.{component}"], scale_by)
        for metric, scale in SCALES.items():
            name = f"map.{metric}.{component}"
            out[name] = heatmap_uri(views[name], scale) if name in views else None
    return out


def colour_bar_css(scale: Scale, stops: int = 9) -> str:
    """A CSS linear-gradient (left to right) of the scale's colour map."""
    lut = colormap_lut(scale.colormap, stops)
    parts = [f"rgb({r},{g},{b}) {100 * k / (stops - 1):.1f}%" for k, (r, g, b) in enumerate(lut)]
    return "linear-gradient(to right, " + ", ".join(parts) + ")"
