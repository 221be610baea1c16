"""beam_width = balanced: each beam's differential width scaled by the factor a pilot of
its step finds along it (approx.splat.Splatter.balance_map, splat/balance.*.glsl): the
pixel's blur bias (its Laplacian) against its noise (two interleaved halves of the beams).

Checked here: the factors stay in their bounds and change the widths. Elsewhere: the
kernels the measured frame reads are the ones drawn (the decomposition's A image is the
real frames' mean: tests/reports/test_kernels.py); the rule beats the differential widths
against ground truth and a wrong curvature does not (tests/cross/test_balanced_widths.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from volcaustics.approx import Renderer
from volcaustics.approx.params import PRESETS
from volcaustics.approx.splat import record_kernels
from volcaustics.scenes import load_builtin

SIZE = 64
BEAMS = dataclasses.replace(PRESETS["beams"], width=SIZE, height=SIZE, light_res=128, photon_res=48,
                            fresnel="deterministic", fresnel_splits=0, split_every=1, steps=4)


def _sigma0(frame, p) -> np.ndarray:
    return np.concatenate([record_kernels(r, p)[:, 0] for r in frame.records if len(r)])


def test_balanced_widths_are_the_differential_ones_times_a_bounded_factor(ctx):
    """Per beam σ0 (balanced) / σ0 (differential) of the same photon and step lies within
    [1/8, 1] (BALANCE_MIN, BALANCE_MAX; float32 rounding of exp and a product allowed), and
    the rule narrows some of sphere1's beams and keeps others."""
    scene = load_builtin("sphere1")
    renderer = Renderer(scene, ctx)
    try:
        differential = renderer.render(scene, dataclasses.replace(BEAMS, beam_width="differential"))
        balanced = renderer.render(scene, dataclasses.replace(BEAMS, beam_width="balanced"))
    finally:
        renderer.release()
    ratio = _sigma0(balanced, dataclasses.replace(BEAMS, beam_width="balanced")) / _sigma0(differential, BEAMS)
    assert ratio.min() >= 0.125 * (1 - 1e-5) and ratio.max() <= 1.0 + 1e-5
    assert (ratio < 0.9).any() and (ratio > 0.999).any()
