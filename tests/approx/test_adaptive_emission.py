"""Adaptive emission: photons drawn over the light's texels by
importance, weighted by 1/(expected count), so the estimate stays unbiased.

The draw is checked exactly (every texel's expected weighted count is 1), the frame
against uniform emission (the splatted energy agrees within noise), and both against a
deliberately wrong draw (no weights) that they must flag.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from volcaustics.approx import Renderer, trace
from volcaustics.approx.cost import frame_cost
from volcaustics.approx.emission import draw_slots
from volcaustics.approx.layers import BOTH
from volcaustics.approx.light import LightFrustum
from volcaustics.approx.params import QUICK
from volcaustics.scenes import resolve_scene
from volcaustics.scenes.bounds import medium_bounds

SEEDS = 6
Z_LIMIT = 4.0  # two-sided z of two means over SEEDS frames each: false alarm ~6e-5


def test_the_draw_gives_every_texel_its_expected_power():
    """Systematic sampling: a texel of importance q gets ⌊Nq/Q⌋ or ⌈Nq/Q⌉ slots, and
    over the random offset E[count]·weight = 1 for every texel; empty texels get none."""
    rng = np.random.default_rng(3)
    q = rng.gamma(0.5, size=4096) * (rng.random(4096) < 0.6)
    expected = q.size * q / q.sum()
    trials = 400
    weighted = np.zeros(q.size)
    for seed in range(trials):
        slots = draw_slots(q, seed)
        counts = np.bincount(slots["texel"], minlength=q.size)
        assert np.all(counts >= np.floor(expected) - 1e-9) and np.all(counts <= np.ceil(expected) + 1e-9)
        assert counts[q == 0].sum() == 0
        weighted += np.bincount(slots["texel"], weights=slots["weight"], minlength=q.size)
    mean = weighted[q > 0] / trials
    # per texel the weighted count is (⌊m⌋ or ⌈m⌉)/m: its spread over `trials` offsets bounds the error
    frac = expected[q > 0] - np.floor(expected[q > 0])
    se = np.sqrt(frac * (1 - frac) / trials) / expected[q > 0]
    assert np.all(np.abs(mean - 1.0) <= 5 * se + 1e-6)
    # negative control: unweighted slots (weight 1) miss every texel's power by its expected count
    assert np.abs(np.bincount(slots["texel"], minlength=q.size)[q > 0] / expected[q > 0] - 1).max() > 0.5


def test_nothing_important_draws_no_photon():
    slots = draw_slots(np.zeros(64), seed=1)
    assert np.all(slots["texel"] == -1)


def test_importance_is_the_photon_power_with_the_gain_at_a_silhouette(ctx):
    """On a sphere seen from the spot, the importance over the uniform photon's power
    (falloff × solid angle) is 1 + 3·e: at most 4 anywhere, and exactly 4 on the rim,
    where a neighbour is uncovered; 0 off the sphere."""
    scene = resolve_scene("sphere1")
    params = dataclasses.replace(QUICK, emission="adaptive")
    renderer = Renderer(scene)
    try:
        tracer = trace.PhotonTracer(renderer.ctx, params)
        frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
        res = params.photon_res
        emission_map = renderer.light_maps.render_light_map(frustum, res, facing=BOTH)
        emission_map.surface.use(location=0)
        q = tracer.importance_map(scene, frustum, res).reshape(res, res)
        covered = np.frombuffer(emission_map.surface.read(), np.float32).reshape(res, res, 4)[..., 0] > 0
        emission_map.release()
    finally:
        renderer.release()
    power = frustum.texel_solid_angles(res).reshape(res, res)
    assert np.all(q[~covered] == 0)
    inside = covered & (q > 0)
    gain = q[inside] / power[inside]  # divided by the solid angle: the falloff × (1 + 3e)
    assert gain.max() <= 4.0 * (1 + 1e-5)
    rim = covered & ~(np.roll(covered, 1, 0) & np.roll(covered, -1, 0) & np.roll(covered, 1, 1)
                      & np.roll(covered, -1, 1))
    rim[0, :] = rim[-1, :] = rim[:, 0] = rim[:, -1] = False
    core = covered & ~rim
    ratio = np.median(q[rim & (q > 0)] / power[rim & (q > 0)]) / np.median(q[core] / power[core])
    assert ratio > 1.5  # the rim's gain of 4 against the sphere's own (1 + 3e with e < 1 where it turns gently)


def _caustic_energies(scene, params, seeds=SEEDS) -> np.ndarray:
    renderer = Renderer(scene)
    try:
        out = []
        for seed in range(seeds):
            frame = renderer.render(scene, dataclasses.replace(params, seed=seed))
            out.append(float(sum(np.asarray(c, np.float64).sum() for c in frame.caustic_steps)))
        return np.array(out)
    finally:
        renderer.release()


def _z(a: np.ndarray, b: np.ndarray) -> float:
    return float((a.mean() - b.mean()) / np.hypot(a.std(ddof=1) / np.sqrt(len(a)), b.std(ddof=1) / np.sqrt(len(b))))


@pytest.mark.slow  # statistical: a z-test over frames of both emissions (about 6 s a scene)
@pytest.mark.parametrize("name", ["sphere1", "bunny"])
def test_adaptive_emission_splats_the_uniform_energy_in_expectation(name):
    scene = resolve_scene(name)
    uniform = _caustic_energies(scene, QUICK)
    adaptive = _caustic_energies(scene, dataclasses.replace(QUICK, emission="adaptive"))
    assert abs(_z(adaptive, uniform)) < Z_LIMIT, (uniform, adaptive)


def test_unweighted_adaptive_emission_is_flagged(monkeypatch):
    """Negative control: the same draw with every weight 1 (photons of the uniform power
    wherever they land) must fail the test above."""
    def unweighted(importance, seed):
        slots = draw_slots(importance, seed)
        slots["weight"] = 1.0
        return slots

    monkeypatch.setattr(trace, "draw_slots", unweighted)
    scene = resolve_scene("sphere1")
    uniform = _caustic_energies(scene, QUICK, seeds=3)
    wrong = _caustic_energies(scene, dataclasses.replace(QUICK, emission="adaptive"), seeds=3)
    assert abs(_z(wrong, uniform)) > Z_LIMIT


def test_adaptive_emission_spends_every_photon_and_counts_its_reads():
    """All photon_res² slots start on a surface (uniform: only the covered texels), and the
    frame cost counts the importance pass's 5 reads per texel."""
    scene = resolve_scene("sphere1")
    renderer = Renderer(scene)
    try:
        uniform = renderer.render(scene, QUICK)
        adaptive = renderer.render(scene, dataclasses.replace(QUICK, emission="adaptive"))
    finally:
        renderer.release()
    slots = QUICK.photon_res ** 2
    assert len(uniform.records[0]) < slots == len(adaptive.records[0])
    cost_u = frame_cost(uniform.records, QUICK.resolved(scene))
    cost_a = frame_cost(adaptive.records, dataclasses.replace(QUICK, emission="adaptive").resolved(scene))
    assert cost_a["emission_reads"] - cost_u["emission_reads"] == 5 * slots + 2 * (slots - len(uniform.records[0]))
    assert cost_u["total"] == cost_u["map_reads"] + cost_u["emission_reads"] + cost_u["splats"]
