"""Procedural density fields ρ(x) ≥ 0 for heterogeneous media (``[medium.density]``).

Each field is a function of world points (N×3 float64, metres) to densities (N float64,
≥ 0) with named parameters, registered in :data:`FIELDS`; ``scenes.density`` bakes it
onto the medium's grid, so both renderers read the same trilinear grid.

* ``height_fog``: ρ = density · exp(−max(y − base, 0) / scale_height): a fog bank
  thickest at and below ``base``, thinning upward (the exponential height fog of
  engines: Hillaire 2015, "Physically based and unified volumetric rendering in Frostbite").
* ``plume``: a rising column of smoke from ``center`` up ``height`` metres, Gaussian across
  (``radius``, widening by ``spread`` at the top) times seeded fractal value noise
  (``octaves`` of ``frequency`` cycles per metre, each octave twice the last at half the
  amplitude: fBm, Musgrave et al. 1989), faded in and out at its ends.
* ``box``: ``inside`` within the axis-aligned box (``min``, ``max``), ``outside`` elsewhere:
  a slab of two densities, whose transmittance is known in closed form (the analytic checks).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .rng import uniform

FIELD_VERSION = 1  # bump when a field's values change for the same parameters (in the scene hash)


@dataclass(frozen=True)
class FieldParam:
    """One parameter: ``kind`` is ``"number"``, ``"integer"`` or ``"point"`` (x, y, z in metres)."""

    kind: str
    default: Any
    low: float
    high: float
    doc: str


@dataclass(frozen=True)
class Field:
    func: Callable[..., np.ndarray]
    params: dict[str, FieldParam]
    doc: str


def height_fog(points: np.ndarray, *, density: float, base: float, scale_height: float) -> np.ndarray:
    height = np.maximum(points[:, 1] - base, 0.0)
    return density * np.exp(-height / scale_height)


def value_noise(points: np.ndarray, seed: int) -> np.ndarray:
    """Value noise in [0, 1): seeded lattice values (``scenes.rng.uniform``) at integer points,
    blended with the quintic fade 6t⁵ − 15t⁴ + 10t³ (Perlin 2002)."""
    cell = np.floor(points)
    t = points - cell
    fade = t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    base = cell.astype(np.int64)
    out = np.zeros(len(points))
    for corner in range(8):
        offset = np.array([(corner >> 0) & 1, (corner >> 1) & 1, (corner >> 2) & 1])
        ijk = (base + offset).astype(np.uint32)  # negative lattice points wrap, as uint32 does
        value = uniform(seed, ijk[:, 0], ijk[:, 1], ijk[:, 2]).astype(np.float64)
        weight = np.prod(np.where(offset == 1, fade, 1.0 - fade), axis=1)
        out += weight * value
    return out


def fbm(points: np.ndarray, *, seed: int, octaves: int, frequency: float) -> np.ndarray:
    """Fractal sum of ``octaves`` value noises, normalised to [0, 1)."""
    total, amplitude, norm = np.zeros(len(points)), 1.0, 0.0
    for octave in range(octaves):
        total += amplitude * value_noise(points * frequency * 2.0**octave, seed + octave)
        norm += amplitude
        amplitude *= 0.5
    return total / norm


def _smoothstep(edge0: float, edge1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - edge0) / (edge1 - edge0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def plume(points: np.ndarray, *, density: float, center: tuple[float, float, float], radius: float,
          height: float, spread: float, seed: int, octaves: int, frequency: float) -> np.ndarray:
    c = np.asarray(center, np.float64)
    h = (points[:, 1] - c[1]) / height
    across = np.hypot(points[:, 0] - c[0], points[:, 2] - c[2]) / (radius * (1.0 + spread * np.clip(h, 0.0, 1.0)))
    ends = _smoothstep(0.0, 0.1, h) * (1.0 - _smoothstep(0.8, 1.0, h))
    noise = np.clip(1.6 * fbm(points, seed=seed, octaves=octaves, frequency=frequency) - 0.3, 0.0, None)
    return density * np.exp(-0.5 * across * across) * ends * noise


def box(points: np.ndarray, *, min: tuple[float, float, float], max: tuple[float, float, float],  # noqa: A002
        inside: float, outside: float) -> np.ndarray:
    within = np.all((points >= np.asarray(min)) & (points <= np.asarray(max)), axis=1)
    return np.where(within, inside, outside)


_DENSITY = FieldParam("number", 1.0, 0.0, 1e6, "density at the field's thickest (× the medium's sigma_s, sigma_a)")
FIELDS: dict[str, Field] = {
    "height_fog": Field(height_fog, {
        "density": _DENSITY,
        "base": FieldParam("number", 0.0, -1e6, 1e6, "height (y, m) at and below which the density is full"),
        "scale_height": FieldParam("number", 0.5, 1e-3, 1e6, "height (m) over which the density falls by e"),
    }, "exponential height fog"),
    "plume": Field(plume, {
        "density": _DENSITY,
        "center": FieldParam("point", (0.0, 0.0, 0.0), -1e6, 1e6, "the column's foot (m)"),
        "radius": FieldParam("number", 0.2, 1e-3, 1e6, "the column's Gaussian radius at its foot (m)"),
        "height": FieldParam("number", 1.5, 1e-3, 1e6, "the column's height (m)"),
        "spread": FieldParam("number", 1.0, 0.0, 100.0, "how much wider it is at the top (× radius)"),
        "seed": FieldParam("integer", 1, 0, 2**31 - 1, "the noise's seed"),
        "octaves": FieldParam("integer", 4, 1, 8, "the noise's octaves"),
        "frequency": FieldParam("number", 3.0, 1e-3, 1e3, "the first octave's frequency (cycles per m)"),
    }, "a rising smoke plume of seeded fractal noise"),
    "box": Field(box, {
        "min": FieldParam("point", (-1.0, -1.0, -1.0), -1e6, 1e6, "the box's low corner (m)"),
        "max": FieldParam("point", (1.0, 1.0, 1.0), -1e6, 1e6, "the box's high corner (m)"),
        "inside": FieldParam("number", 1.0, 0.0, 1e6, "the density inside the box"),
        "outside": FieldParam("number", 0.0, 0.0, 1e6, "the density outside it"),
    }, "constant density in a box, another outside (a slab of two densities)"),
}


def field_values(name: str, params: dict[str, Any], points: np.ndarray) -> np.ndarray:
    """The field ``name`` with ``params`` at ``points`` (N×3 float64, m): N float64, ≥ 0."""
    return np.asarray(FIELDS[name].func(np.asarray(points, np.float64), **params), np.float64)
