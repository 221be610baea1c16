"""Renderer controls: #defines that are not parameters of the method, given to a
Renderer as ``controls={NAME: value}`` (part of the programs' cache key), for negative
controls, benches and the decomposition's exact-transmittance images."""

from __future__ import annotations

# CLIP_TO_OBJECTS clips searched segments to the specular objects' box as well
# (trace.comp.glsl; off by default: it changed little and not always for the better,
# bench/agreement.py, docs/decisions.md "Clip to objects"); the others are deliberate faults
# a test must see flagged.
# name → (the programs it goes to: "trace" the emission and trace programs, "splat" the
# splat programs (every mode's for EXACT_*, the density and beam modes' for the others),
# "frame" none: the renderer reads it; a tuple: several; what it does)
CONTROLS = {
    "CLIP_TO_OBJECTS": ("trace", "clip searched segments to the specular objects' box too"),
    "DIFFERENTIAL_UNPROPAGATED": ("trace", "photon differentials not propagated through interactions "
                                           "(common/differential.glsl)"),
    "EMISSION_SHIFT": ("trace", "photons leave this many texels off their emission points (emit.comp.glsl)"),
    "GRID_IGNORED": ("trace", "heterogeneous media: delta tracking ignores the density grid, collisions at the "
                              "mean rate sigma_bar everywhere (common/density.glsl)"),
    "MAJORANT_SCALE": ("trace", "heterogeneous media: delta tracking's majorants times this factor (below 1: "
                                "below the density, a wrong tracker; common/density.glsl)"),
    "EXACT_MARCH": (("trace", "splat"), "heterogeneous media: every fixed march exact (the light's path, a "
                                        "segment's, along a beam; common/density.glsl's exact_depth): the "
                                        "decomposition's march term"),
    "EXACT_EYE": ("splat", "heterogeneous media: splats' and beams' transmittance to the eye exact instead of "
                           "the camera volume's: the decomposition's camera_volume term"),
    "DENSITY_IGNORED": ("splat", "density splats ignore the density pre-pass (splat/density.*.glsl)"),
    "BEAM_NO_SINE": ("splat", "beams without the estimator's 1/sin θ (splat/beam.frag.glsl)"),
    "BEAM_NO_CAMERA_TRANSMITTANCE": ("splat", "beams without the transmittance to the camera (splat/beam.frag.glsl)"),
    "BEAM_CLOSEST_DEPTH": ("splat", "beams depth-tested at their closest approach alone, not cut at the surface "
                                    "(splat/beam.frag.glsl)"),
    "BEAM_RECTANGLE": ("splat", "beams drawn as their widest kernel's rectangle, not a trapezoid "
                                "(splat/beam.vert.glsl)"),
    "BEAM_FULLSCREEN": ("splat", "beams drawn over the whole image, not the quad that holds their kernels "
                                 "(splat/beam.vert.glsl)"),
    "BALANCE_MIRRORED": ("splat", "balanced beam widths take the curvature of the mirrored pilot pixel: a wrong "
                                  "curvature (splat/balance.frag.glsl)"),
    "STEP_IMAGES_KEPT": ("frame", "the step images not cleared between frames: what a frame leaves in the "
                                  "resources it keeps reaches the next (approx.renderer)"),
}


def check_controls(controls: dict | None) -> dict:
    """``controls`` as a plain dict, every name one of :data:`CONTROLS` (ValueError otherwise)."""
    controls = dict(controls or {})
    unknown = sorted(set(controls) - set(CONTROLS))
    if unknown:
        raise ValueError(f"unknown renderer controls {unknown}; expected some of {', '.join(CONTROLS)}")
    return controls


EXACT_TRANSMITTANCE = ("EXACT_MARCH", "EXACT_EYE")  # the splat programs of every mode take these


def control_programs(name: str) -> tuple[str, ...]:
    """The programs control ``name`` goes to ("trace", "splat", "frame")."""
    target = CONTROLS[name][0]
    return target if isinstance(target, tuple) else (target,)


def controls_for(controls: dict | None, program: str) -> dict:
    """The controls of ``controls`` that go to ``program`` ("trace" or "splat")."""
    return {k: v for k, v in check_controls(controls).items() if program in control_programs(k)}
