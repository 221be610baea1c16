"""A scene's density grid: its medium's ``scenes.density.Density`` baked over its medium box
(``scenes.bounds``), the grid both renderers read; None for a homogeneous medium."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .bounds import medium_bounds
from .density import DensityGrid, baked_grid

if TYPE_CHECKING:
    from .model import Scene


def density_grid(scene: Scene) -> DensityGrid | None:
    """The grid of ``scene``'s medium density (None for a homogeneous medium)."""
    density = scene.medium.density
    if density is None:
        return None
    lo, hi = medium_bounds(scene)
    return baked_grid(density, tuple(lo), tuple(hi))
