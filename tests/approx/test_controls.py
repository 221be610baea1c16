"""Renderer controls (``approx.controls.CONTROLS``): #defines that are not parameters of the
method reach the programs only through a Renderer's ``controls``, never a module global."""


import pytest

from volcaustics.approx import ApproxParams
from volcaustics.approx.controls import CONTROLS, check_controls
from volcaustics.approx.trace import PhotonTracer


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
