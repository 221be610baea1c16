"""``approx.emission``'s rays: the light's true distribution carries the spot's power (a
negative control without its profile does not), and the approximation's own rays are
the ones ``emit.comp.glsl`` emits along (texel centres, the adaptive draw, a test's
shifted grid), and the exact emission from them lands where the approximation's does."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.shared import flat_spot
from volcaustics.approx import Renderer
from volcaustics.approx.emission import approx_rays, true_rays
from volcaustics.approx.light import LightFrustum, spot_falloff
from volcaustics.approx.params import QUICK
from volcaustics.scenes import load_builtin
from volcaustics.scenes.bounds import medium_bounds


def _spot_power(light) -> float:
    """∫ I·falloff(ω) dω over the cone, by a fine quadrature in θ (mean of the channels)."""
    theta = np.linspace(0.0, math.radians(light.cutoff_angle), 200_001)
    axis = np.asarray(light.direction, np.float64)
    other = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    other /= np.linalg.norm(other)
    d = np.cos(theta)[:, None] * axis + np.sin(theta)[:, None] * other
    f = spot_falloff(light, d).astype(np.float64) * np.sin(theta)
    integral = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(theta)))
    return 2.0 * math.pi * integral * float(np.mean(light.intensity))


def test_true_rays_carry_the_spots_power_and_a_flat_profile_does_not():
    """Σ power of the jittered photons over 8 seeds against the quadrature of I·falloff
    over the cone: within 4 standard errors of the seeds' spread (tolerance: that
    spread, measured). Without the profile (1 up to the cutoff) the total is the
    cone's I·Ω instead, many standard errors away (the negative control)."""
    scene = load_builtin("sphere1")
    light = dataclasses.replace(scene.light, beam_width=8.0)  # a wide transition: the profile matters
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    expected = _spot_power(light)
    totals = np.array([true_rays(light, frustum, 64, seed).power.mean(axis=1).sum() for seed in range(8)])
    se = totals.std(ddof=1) / math.sqrt(len(totals))
    assert abs(totals.mean() - expected) <= 4 * se + 1e-6 * expected, (totals.mean(), expected, se)
    flat = np.array([true_rays(light, frustum, 64, seed, profile=flat_spot).power.mean(axis=1).sum()
                     for seed in range(8)])
    assert abs(flat.mean() - expected) > 20 * (se + flat.std(ddof=1) / math.sqrt(len(flat)))


@pytest.mark.parametrize("changes, shift", [
    ({}, 0.0), ({"emission": "adaptive"}, 0.0), ({}, 0.5), ({"emission_jitter": "random"}, 0.0),
    ({"emission_jitter": "sobol"}, 0.0), ({"emission": "adaptive", "emission_jitter": "sobol"}, 0.0)])
def test_the_approximations_rays_are_the_ones_it_emits(gl_context, changes, shift):
    """Every photon the emission shader starts lies on its ray from
    ``Renderer.emission_rays`` (the direction from the light to its start, to float32
    rounding), for texel centres, every emission_jitter, the adaptive draw and a test's half-texel shift
    (``EMISSION_SHIFT``); the rays of the unshifted grid miss the shifted photons (the
    negative control)."""
    scene = load_builtin("sphere1")
    params = dataclasses.replace(QUICK, photon_res=64, light_res=64, width=32, height=32, **changes)
    renderer = Renderer(scene, controls={"EMISSION_SHIFT": shift} if shift else None)
    try:
        (rays,) = renderer.emission_rays(scene, params, [5])
        (first,) = renderer.first_records(scene, params, [5])
    finally:
        renderer.release()
    assert len(first) > 100
    to_start = first["start"].astype(np.float64) - np.asarray(scene.light.position)
    to_start /= np.linalg.norm(to_start, axis=1, keepdims=True)
    where = np.searchsorted(rays.photon, first["photon"])
    assert np.array_equal(rays.photon[where], first["photon"])
    cosine = np.einsum("ij,ij->i", to_start, rays.direction[where])
    assert np.all(cosine > 1 - 1e-9), 1 - cosine.min()  # measured: 1 − cos ≤ 3e-15 (float32 rounding of the start)
    if shift:
        frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
        centres = approx_rays(scene.light, frustum, 64, 5)
        assert np.median(np.einsum("ij,ij->i", to_start, centres.direction[first["photon"]])) < 1 - 1e-7


def test_every_emission_rule_has_its_rays():
    """The parameter's choices are the rules ``approx_rays`` mirrors: a new rule fails here
    until the exact images can replay it from the emission ray."""
    from volcaustics.approx.emission import RULES
    from volcaustics.approx.params import PARAMS

    (emission,) = [p for p in PARAMS if p.name == "emission"]
    assert tuple(emission.choices) == RULES
