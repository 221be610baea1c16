"""Adaptive emission (``emission`` = adaptive; docs/approx.md: the
photon_res² photon slots drawn over the light's texels in proportion to an importance
(``emission/importance.comp.glsl``: the uniform photon's power times 1 + gain where the
surface turns sharply or breaks), instead of one slot per texel.

The paper's future work: "adaptive sampling where sharp curvatures are likely to produce
visible caustic beams" (Wang, Wang & Chen, §7). The draw is systematic sampling of the
importance's cumulative sum (one random offset per frame, slots evenly spaced along it):
texel i receives n_i slots with E[n_i] = N·q_i/Q exactly (N slots, Q = Σq), each with
weight Q/(N·q_i), so the expected power of every texel is its uniform photon's — the
estimate stays unbiased whatever the importance (tests/approx/test_adaptive_emission.py).
Slots fall in texel order, so photon index ranges still cover the light in stripes
(``experiment.exact.interleaved_subsets``).

The draw runs on the host (numpy over photon_res² floats); a GPU implementation would
scan the importance in parallel. Its cost in map reads is counted like the search's
(:func:`emission_reads`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.scenes.rng import uniform
from volcaustics.scenes.sobol import morton, sobol_2d

from .light import spot_falloff

if TYPE_CHECKING:
    from volcaustics.scenes.model import SpotLight

    from .light import LightFrustum

# One slot of emit.comp.glsl's Slots buffer: the texel (row-major index, -1: no photon)
# and the weight that multiplies the uniform photon's power.
SLOT_DTYPE = np.dtype([("texel", "<i4"), ("weight", "<f4")])

# The importance pass reads each texel and its 4 neighbours; emission reads the map and the
# geometric normals of a photon's texel, and ray differentials 2 or 4 neighbours more for the
# curvature (emit.comp.glsl's emission_curvature; 4 counted, its worst case).
IMPORTANCE_READS = 5
EMISSION_READS = 2
CURVATURE_READS = 4


def draw_slots(importance: np.ndarray, seed: int) -> np.ndarray:
    """N slots (SLOT_DTYPE) over the N texels of ``importance`` (≥ 0, row-major): the
    systematic sample of its cumulative sum at (j + u)/N, u uniform in [0, 1) from
    ``seed``; all slots empty (texel -1) when nothing is important."""
    q = np.asarray(importance, np.float64).ravel()
    n = q.size
    slots = np.zeros(n, SLOT_DTYPE)
    total = q.sum()
    if not np.isfinite(total) or total <= 0.0:
        slots["texel"] = -1
        return slots
    u = np.random.default_rng([seed, 0xE5]).random()
    cumulative = np.cumsum(q) / total
    texel = np.searchsorted(cumulative, (np.arange(n) + u) / n, side="right")
    texel = np.minimum(texel, n - 1)  # (j + u)/N < 1 = cumulative[-1] up to rounding
    slots["texel"] = texel
    slots["weight"] = total / (n * q[texel])
    return slots


def emission_reads(photon_res: int, emitted: int, *, emission: str, differentials: bool) -> int:
    """Emission-map texels a frame reads: the importance pass's (adaptive emission) and
    each photon's own (``emitted``: photons that hit a surface), with the curvature
    neighbours of photons that carry ray differentials (``params.carries_differentials``)."""
    per_photon = EMISSION_READS + (CURVATURE_READS if differentials else 0)
    return (IMPORTANCE_READS * photon_res**2 if emission == "adaptive" else 0) + per_photon * emitted


@dataclass
class EmissionRays:
    """Photons leaving the light: the numpy twin of ``emit.comp.glsl``'s rays, before
    the medium's transmittance to the first surface and the first interaction.

    photon: N photon indices (uint32): the slot (A's adaptive emission) or the texel
        (row-major, row 0 at the bottom) the photon belongs to.
    direction: N×3 unit world directions from the light (float64).
    power: N×3 RGB power (W) the photon carries from the light.
    """

    photon: np.ndarray
    direction: np.ndarray
    power: np.ndarray


def _random_within(seed: int, index: np.ndarray) -> np.ndarray:
    """N×2 uniform points in the texel of each photon ``index``, u(seed, index, 0, 2..3)
    (``emit.comp.glsl``'s adaptive photons)."""
    return np.stack([uniform(seed, index.astype(np.uint32), 0, dim) for dim in (2, 3)], axis=1).astype(np.float64)


def _rays(light, frustum, photon_res: int, texel: np.ndarray, within: np.ndarray) -> tuple:
    """(unit directions, image-plane points) through ``within`` ((0, 0) to (1, 1)) of
    the row-major ``texel`` indices, as ``emission/map.glsl``'s texel_plane."""
    xy = np.stack([texel % photon_res, texel // photon_res], axis=1).astype(np.float64)
    plane = ((xy + within) / photon_res * 2.0 - 1.0) * frustum.tan_half
    d = np.concatenate([plane, np.ones((len(plane), 1))], axis=1) @ frustum.basis.T
    return d / np.linalg.norm(d, axis=1, keepdims=True), plane


# the emission rules approx_rays mirrors (the parameter ``emission``'s choices): a new rule
# adds its rays there, so that the decomposition's exact images replay what A emits
RULES = ("uniform", "adaptive")


def _within(jitter: str, seed: int, photon, texel: np.ndarray, photon_res: int, shift: float) -> np.ndarray:
    """N×2 points in each photon's texel, as ``emit.comp.glsl`` places them; ``photon``:
    adaptive emission's slots (None: one photon per texel)."""
    if photon is not None:
        return sobol_2d(seed, photon).astype(np.float64) if jitter == "sobol" else _random_within(seed, photon)
    if jitter == "sobol":
        return sobol_2d(seed, morton(texel % photon_res, texel // photon_res)).astype(np.float64)
    if jitter == "random":
        return _random_within(seed, texel)
    return np.full((len(texel), 2), 0.5 + shift)


def approx_rays(light: SpotLight, frustum: LightFrustum, photon_res: int, seed: int, *, slots: np.ndarray | None = None,
                shift: float = 0.0, jitter: str = "center") -> EmissionRays:
    """The approximation's own emission (``emit.comp.glsl``): one photon per texel
    through the point ``jitter`` gives (its centre, moved by ``shift`` texels: a test's
    wrong grid; random: u(seed, texel, 0, 2..3); sobol: ``scenes.sobol.sobol_2d`` of the
    texel's Morton index), or with ``slots`` (adaptive emission, SLOT_DTYPE) one per slot
    through a random point of its texel, u(seed, slot, 0, 2..3), or the slot's Sobol
    point; power I·falloff(d)·ΔΩ(texel)·weight."""
    n = photon_res * photon_res
    if slots is None:
        photon = texel = np.arange(n, dtype=np.int64)
        weight = np.ones(n)
        within = _within(jitter, seed, None, texel, photon_res, shift)
    else:
        photon = np.flatnonzero(slots["texel"] >= 0)
        texel, weight = slots["texel"][photon].astype(np.int64), slots["weight"][photon].astype(np.float64)
        within = _within(jitter, seed, photon, texel, photon_res, shift)
    d, _ = _rays(light, frustum, photon_res, texel, within)
    solid_angle = frustum.texel_solid_angles(photon_res).ravel()[texel]
    power = (np.asarray(light.intensity, np.float64)[None, :] * spot_falloff(light, d)[:, None]
             * (solid_angle * weight)[:, None])
    return EmissionRays(photon.astype(np.uint32), d, power)


def true_rays(light: SpotLight, frustum: LightFrustum, photon_res: int, seed: int,
              profile: Callable[[SpotLight, np.ndarray], np.ndarray] | None = None) -> EmissionRays:
    """Photons from the light's true distribution I·falloff(ω) dω: one per texel through
    a uniformly random point of it, u(seed, texel, 0, 2..3), with power
    I·falloff(d)·ΔA/ρ³ (ΔA the texel's area on the unit-distance image plane, ρ the
    point's distance from the light: dω = dA/ρ³), so each texel's expected power is
    ∫ I·falloff dω over it exactly. ``profile``: the falloff (light, directions) →
    values, ``approx.light.spot_falloff`` when None (a test drops it)."""
    n = photon_res * photon_res
    texel = np.arange(n, dtype=np.int64)
    d, plane = _rays(light, frustum, photon_res, texel, _random_within(seed, texel))
    area = (2.0 * frustum.tan_half / photon_res) ** 2
    rho = np.sqrt(1.0 + np.sum(plane * plane, axis=1))
    falloff = (profile or spot_falloff)(light, d).astype(np.float64)
    power = np.asarray(light.intensity, np.float64)[None, :] * (falloff * area / rho**3)[:, None]
    return EmissionRays(texel.astype(np.uint32), d, power)
