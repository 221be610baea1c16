"""Adaptive emission (``emission`` = adaptive; DESIGN.md "approx: variants"): the
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
(``reports.experiment.exact.interleaved_subsets``).

The draw runs on the host (numpy over photon_res² floats); a GPU implementation would
scan the importance in parallel. Its cost in map reads is counted like the search's
(:func:`emission_reads`).
"""

from __future__ import annotations

import numpy as np

# One slot of emit.comp.glsl's Slots buffer: the texel (row-major index, -1: no photon)
# and the weight that multiplies the uniform photon's power.
SLOT_DTYPE = np.dtype([("texel", "<i4"), ("weight", "<f4")])

# The importance pass reads each texel and its 4 neighbours; emission reads the map and the
# geometric normals of a photon's texel, and adaptive splats 2 or 4 neighbours more for the
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


def emission_reads(photon_res: int, emitted: int, *, emission: str, splat: str) -> int:
    """Emission-map texels a frame reads: the importance pass's (adaptive emission) and
    each photon's own (``emitted``: photons that hit a surface), with adaptive splats'
    curvature neighbours."""
    per_photon = EMISSION_READS + (CURVATURE_READS if splat == "adaptive" else 0)
    return (IMPORTANCE_READS * photon_res**2 if emission == "adaptive" else 0) + per_photon * emitted
