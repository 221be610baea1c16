"""Renderer controls (``approx.controls.CONTROLS``): #defines that are not parameters of the
method reach the programs only through a Renderer's ``controls``, never a module global."""

import dataclasses

import numpy as np
import pytest

from volcaustics.approx import ApproxParams, Renderer
from volcaustics.approx.controls import CONTROLS, check_controls
from volcaustics.approx.params import QUICK
from volcaustics.approx.trace import PhotonTracer
from volcaustics.scenes import load_builtin


def test_a_control_reaches_the_tracers_defines_and_its_key():
    plain = PhotonTracer.defines(ApproxParams())
    clipped = PhotonTracer.defines(ApproxParams(), {"CLIP_TO_OBJECTS": 1})
    assert "CLIP_TO_OBJECTS" not in plain and clipped["CLIP_TO_OBJECTS"] == 1
    assert {k: v for k, v in clipped.items() if k != "CLIP_TO_OBJECTS"} == plain


def test_the_density_controls_go_to_the_splatter_not_the_tracer():
    assert "DENSITY_IGNORED" in CONTROLS
    assert "DENSITY_IGNORED" not in PhotonTracer.defines(ApproxParams(), {"DENSITY_IGNORED": 1})


def test_an_unknown_control_is_refused():
    with pytest.raises(ValueError, match="CLIP_TO_OBJECT"):
        check_controls({"CLIP_TO_OBJECT": 1})  # a typo: silently ignored it would measure the default


def test_the_emission_forced_each_way_sums_to_the_photons_power(ctx):
    """EMISSION_FRESNEL (bench/emission_split.py): a frame whose photons all reflect at R of
    their power and one whose photons all refract at 1 − R of it carry, between them, what
    the stochastic choice carries (each photon whole, whichever way): step 1's powers sum
    to it to float32 rounding; and the reflected frame carries a small share of it (R ≈ 4%
    at normal incidence on glass of IOR 1.5), which an unweighted reflection would not."""
    scene = load_builtin("sphere1")
    params = dataclasses.replace(QUICK, fresnel="stochastic", width=64, height=64, photon_res=64, light_res=64)
    power = {}
    ways = {"stochastic": {}, "reflect": {"EMISSION_FRESNEL": 1}, "refract": {"EMISSION_FRESNEL": 2}}
    for way, controls in ways.items():
        frame = Renderer(scene, ctx, controls=controls).render(scene, params, keep_records=True)
        power[way] = frame.records[0]["power_start"].astype(np.float64).sum(axis=0)
    # float32 sums of ~3k photons
    assert np.allclose(power["reflect"] + power["refract"], power["stochastic"], rtol=1e-5)
    # a sphere seen from its light: R from 4% up, no total internal reflection at the first surface
    assert 0.02 < (power["reflect"] / power["stochastic"]).mean() < 0.2
