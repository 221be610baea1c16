"""Fresnel splitting along the refracted chain (``fresnel_splits``, scenes.splitting): the
rule counts every branch of a photon's tree once at its probability, and the GPU's batches
carry what one photon's choice carries."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from volcaustics.approx import Renderer
from volcaustics.approx.params import QUICK, ApproxParams, ParamError, photon_slots
from volcaustics.scenes import load_builtin
from volcaustics.scenes.splitting import FREE, REFLECT, REFRACT, forced, silent


def _tree_weights(R: list, splits: int, count_silent: bool = False) -> dict:
    """(path of choices up to and including interaction t) → the weight the batches give
    the segment after it, summed over batches and over their free choices at their
    probabilities: what a frame splats in expectation, for a photon whose interaction t
    has reflectance R[t] whatever the path (a test's simplification)."""
    slots = 1
    out: dict = {}

    def walk(batch, t, path, weight):
        if t == len(R):
            return
        choice = int(forced(batch * slots, t, splits, slots))
        options = ({REFLECT: R[t], REFRACT: 1 - R[t]} if choice == FREE
                   else {choice: R[t] if choice == REFLECT else 1 - R[t]})
        for c, w in options.items():
            step = t + 1  # the segment after interaction t is step t + 1's
            if count_silent or not silent(batch * slots, step, splits, slots):
                out[path + (c,)] = out.get(path + (c,), 0.0) + weight * w
            walk(batch, t + 1, path + (c,), weight * w)

    for batch in range(splits + 1):
        walk(batch, 0, (), 1.0)
    return out


@pytest.mark.parametrize("splits", [0, 1, 2, 3])
def test_every_branch_is_splatted_once_at_its_probability(splits):
    R = [0.04, 0.1, 0.3, 0.07, 0.5]
    weights = _tree_weights(R, splits)
    for depth in range(1, len(R) + 1):
        for path in itertools.product((REFLECT, REFRACT), repeat=depth):
            p = np.prod([R[t] if c == REFLECT else 1 - R[t] for t, c in enumerate(path)])
            assert weights.get(path, 0.0) == pytest.approx(p, rel=1e-12), path


def test_splatting_the_silent_segments_is_flagged():
    """Negative control: a batch that splats its share of the refracted chain counts the
    chain's light once more per batch that follows it."""
    weights = _tree_weights([0.04, 0.1, 0.3], 2, count_silent=True)
    assert weights[(REFRACT,)] == pytest.approx(2 * 0.96)  # batches 1 and 2 both


def test_batches_follow_the_chain_to_their_reflection():
    slots = 100
    photon = np.array([5, 105, 205])  # texel 5 in batches 0, 1, 2 of fresnel_splits 2
    assert forced(photon, 0, 2, slots).tolist() == [REFLECT, REFRACT, REFRACT]
    assert forced(photon, 1, 2, slots).tolist() == [FREE, REFLECT, REFRACT]
    assert forced(photon, 2, 2, slots).tolist() == [FREE, FREE, FREE]
    assert silent(photon, 1, 2, slots).tolist() == [False, True, False]
    assert silent(photon, 2, 2, slots).tolist() == [False, False, False]  # batch 1's reflection


def test_a_frames_slots_and_the_parameters_range():
    assert photon_slots(ApproxParams(photon_res=10, fresnel_splits=2)) == 300
    with pytest.raises(ParamError, match="fresnel_splits"):
        ApproxParams(fresnel_splits=9)


def test_the_first_surfaces_batches_sum_to_the_photons_power(ctx):
    """fresnel_splits = 1 on the GPU: per emission texel, batch 0 (reflected at R of the
    power) and batch 1 (refracted at 1 − R) carry between them what the unsplit photon
    carries, to float32 rounding; batch 0 a small share of it (R ≈ 4% at normal incidence
    on glass of IOR 1.5), which an unweighted reflection would not."""
    scene = load_builtin("sphere1")
    params = dataclasses.replace(QUICK, fresnel="stochastic", width=64, height=64, photon_res=64, light_res=64)
    n = params.photon_res**2
    renderer = Renderer(scene, ctx)
    whole = renderer.render(scene, params, keep_records=True).records[0]
    split = renderer.render(scene, dataclasses.replace(params, fresnel_splits=1), keep_records=True).records[0]
    power = np.zeros((2, n, 3))
    for batch in (0, 1):
        rows = split[split["photon"] // n == batch]
        power[batch, rows["photon"] % n] = rows["power_start"]
    unsplit = np.zeros((n, 3))
    unsplit[whole["photon"]] = whole["power_start"]
    lit = unsplit[:, 0] > 0
    assert lit.sum() > 500
    assert np.allclose(power.sum(axis=0)[lit], unsplit[lit], rtol=1e-5)  # float32 products
    share = power[0, lit, 0] / unsplit[lit, 0]
    assert 0.02 < share.mean() < 0.2  # a sphere seen from its light: R from 4% up, no TIR there


def test_split_every_keeps_the_slots_scenes_splitting_keeps(ctx):
    """split_every = 4 on the GPU: the reflected batch's photons are the slots
    ``scenes.splitting.kept`` keeps (about a quarter of the lit texels) at 4× the power of
    split_every = 1's; the refracted batch is untouched."""
    from volcaustics.scenes.splitting import kept

    scene = load_builtin("sphere1")
    params = dataclasses.replace(QUICK, fresnel="stochastic", width=64, height=64, photon_res=64, light_res=64,
                                 fresnel_splits=1, seed=7)
    n = params.photon_res**2
    renderer = Renderer(scene, ctx)
    every = renderer.render(scene, dataclasses.replace(params, split_every=4), keep_records=True).records[0]
    whole = renderer.render(scene, params, keep_records=True).records[0]
    reflected = whole[whole["photon"] < n]
    keep, factor = kept(params.seed, reflected["photon"], 1, n, 4)
    assert 0.2 < keep.mean() < 0.3
    mine = every[every["photon"] < n]
    assert np.array_equal(mine["photon"], reflected["photon"][keep])
    assert np.allclose(mine["power_start"], reflected["power_start"][keep] * 4, rtol=1e-6)
    assert np.array_equal(every[every["photon"] >= n]["photon"], whole[whole["photon"] >= n]["photon"])
