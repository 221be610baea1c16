"""The splat modes: how a photon's power reaches the image (the parameter ``splat``).

Each mode is one :class:`SplatMode` of :data:`SPLAT_MODES`, registered by name; the
parameter table's choices and help, the renderer's programs and record layout, the cost
model's passes and the decomposition's replay read its properties rather than its name.
A new mode is an entry here, its shaders (``approx/shaders/splat/``, selected by the
``SPLAT_<NAME>`` define) and its rule in the decomposition's kernel replay
(``experiment.kernels.KERNEL_RULES``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class SplatMode:
    """A splat mode. ``help``: its line in the parameter table. ``beams``: no free
    flights; each photon's segment in the medium is drawn as a beam (BEAM_DTYPE rows).
    ``differential_width``: point splats as wide as the photon's ray differential (the
    photons carry differentials). ``density_pass``: a pre-pass counts the step's photons
    per screen cell, from which each splat takes its width."""

    name: str
    help: str
    beams: bool = False
    differential_width: bool = False
    density_pass: bool = False


SPLAT_MODES: dict[str, SplatMode] = {m.name: m for m in (
    SplatMode("fixed", "fixed (paper: splat_radius for every photon)"),
    SplatMode("adaptive", "adaptive (splat_footprints × the photon's footprint, its distance to its neighbours' rays "
                          "carried as a ray differential through every refraction and reflection, within "
                          "[splat_radius/16, 4·splat_radius] and at least a pixel)", differential_width=True),
    SplatMode("density", "density (the radius of a screen disc holding splat_neighbours photons of its step, from a "
                         "pre-pass counting them per 4×4-pixel cell: Abramson's square-root law, within "
                         "[splat_radius/2, 4·splat_radius])", density_pass=True),
    SplatMode("beams", "beams (no free flights: each photon's segment in the medium is a beam, estimated along every "
                       "camera ray that passes within 3·splat_radius of it with a 1-D Gaussian kernel: Jarosz et al. "
                       "2011)", beams=True),
)}


def splat_mode(params: Any) -> SplatMode:
    """The :class:`SplatMode` of ``params`` (anything with a ``splat``; fixed without one)."""
    return SPLAT_MODES[getattr(params, "splat", "fixed")]


def splat_help() -> str:
    """The parameter table's help of ``splat``: every mode's line."""
    lines = [m.help for m in SPLAT_MODES.values()]
    return "the splat kernel's width: " + ", ".join(lines[:-1]) + " or " + lines[-1]
