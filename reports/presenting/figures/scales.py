"""The fixed colour scales of error maps (the same for every scene and run, so that maps
compare across scenes, reports and animations: :data:`SCALES`) and the colouring itself."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Scale:
    """A fixed colour scale: values from ``low`` to ``high`` (log10 between them when
    ``log``) onto the matplotlib colour map ``colormap``; below/above clip to its ends;
    NaN (pixels not compared) is drawn in ``nan_colour``."""

    low: float
    high: float
    log: bool
    colormap: str
    label: str
    nan_colour: tuple = (128, 128, 128)

    def unit(self, values: np.ndarray) -> np.ndarray:
        """values mapped to [0, 1] (NaN stays NaN)."""
        v = np.asarray(values, np.float64)
        if self.log:
            with np.errstate(divide="ignore", invalid="ignore"):
                v = (np.log10(np.maximum(v, 1e-300)) - np.log10(self.low)) / (np.log10(self.high) - np.log10(self.low))
        else:
            v = (v - self.low) / (self.high - self.low)
        return np.where(np.isnan(values), np.nan, np.clip(v, 0.0, 1.0))

    def ticks(self) -> list:
        """(position in [0, 1], label) along the bar."""
        if self.log:
            lo, hi = int(np.floor(np.log10(self.low))), int(np.ceil(np.log10(self.high)))
            return [((k - lo) / (hi - lo), f"1e{k}") for k in range(lo, hi + 1)]
        return [(k / 4, f"{self.low + k * (self.high - self.low) / 4:g}") for k in range(5)]

    def to_dict(self) -> dict:
        return {"low": self.low, "high": self.high, "log10": self.log, "colormap": self.colormap,
                "label": self.label, "not_compared": "grey"}


# per-pixel relative MSE spans decades (caustic medians near 1, combined near 1e-2): log10 over 5 decades;
# HDR-FLIP's error is in [0, 1] by construction (Andersson et al. 2021), drawn with FLIP's own magma map
SCALES = {"per_pixel_relative_mse": Scale(1e-4, 10.0, True, "viridis", "per-pixel relative MSE (log10)"),
          "hdr_flip": Scale(0.0, 1.0, False, "magma", "HDR-FLIP error")}


def colormap_lut(colormap: str, n: int = 256) -> np.ndarray:
    import matplotlib

    return (np.asarray(matplotlib.colormaps[colormap](np.linspace(0.0, 1.0, n)))[:, :3] * 255 + 0.5).astype(np.uint8)


def heatmap_rgb8(values: np.ndarray, scale: Scale) -> np.ndarray:
    """An H×W map (NaN: not compared) coloured on ``scale``: H×W×3 uint8."""
    v = np.asarray(values, np.float64)
    if v.ndim == 3:
        v = v[..., 0]
    u = scale.unit(v)
    lut = colormap_lut(scale.colormap)
    rgb = lut[np.clip(np.nan_to_num(u, nan=0.0) * 255 + 0.5, 0, 255).astype(np.int64)]
    rgb[np.isnan(u)] = scale.nan_colour
    return rgb
