"""splat = density: each photon's kernel from the photons per cell of a pre-pass.

The kernels stay normalised whatever their widths (the image integral is the sum of the
point photons'), dense clusters get narrower kernels than sparse ones, the pre-pass is
counted in the frame cost, and on sphere1 the one-frame error with the density read is
below the same pass with the density ignored (one width for every photon of a frame:
the negative control, the test define DENSITY_IGNORED)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.shared import make_scene, pixel_solid_angles
from volcaustics.approx import Renderer
from volcaustics.approx.camera_pass import CameraView
from volcaustics.approx.cost import DENSITY_READS, frame_cost
from volcaustics.approx.params import QUICK
from volcaustics.approx.splat import Splatter, splat_commands, splats_from_arrays
from volcaustics.metrics.frame import frame_relative_mse
from volcaustics.scenes import load_builtin
from volcaustics.scenes.model import Camera


def _splat(ctx, centres, power, neighbours=16):
    sigma_t = 0.1
    cam = Camera(position=(0.0, 1.0, 3.0), target=(0.0, 1.0, 0.0), fov_y=20.0, width=160, height=160)
    scene = make_scene([], camera=cam, sigma_s=sigma_t, sigma_a=0.0, floor=False)
    view = CameraView(cam, cam.width, cam.height, far=100.0)
    splatter = Splatter(ctx, scene.medium, density=True)
    raw = splats_from_arrays(end=centres, direction=[[0.0, -1.0, 0.0]] * len(centres),
                             power=[[power] * 3] * len(centres))
    records = ctx.buffer(raw.tobytes())
    target = ctx.texture((cam.width, cam.height), 4, dtype="f4")
    empty = ctx.texture((cam.width, cam.height), 4, dtype="f4")
    commands = ctx.buffer(splat_commands(len(raw)))
    splatter.splat(records, commands, view, scene.medium, 0.01, empty, target, neighbours)  # 3σ ≤ 12 cm: in view
    image = np.frombuffer(target.read(), np.float32).reshape(cam.height, cam.width, 4)[..., 0].astype(np.float64)
    for r in (records, target, empty):
        r.release()
    splatter.release()
    _, omega = pixel_solid_angles(cam.fov_y, cam.width)
    d = np.linalg.norm(np.asarray(centres, float) - np.asarray(cam.position), axis=1)  # each point's distance
    return image, omega, float(np.sum(power / (4 * math.pi) * np.exp(-sigma_t * d) / d**2))


def test_density_kernels_keep_the_energy_and_narrow_where_photons_crowd(ctx):
    """A dense cluster (400 photons within 1 cm) and a sparse spread (100 over 30 cm) in
    the plane z = 0, seen from 3 m: Σ L·Ω is the point photons' Σ Φ/(4π)·exp(−σt d)/d² to 1e-4 (the pixel
    masses' erf approximation, as for adaptive splats); the
    cluster's image is narrower than the same photons splatted as a sparse lone one."""
    rng = np.random.default_rng(4)
    dense = np.c_[rng.normal(0.0, 0.005, (400, 2)), np.zeros(400)] + [0.0, 1.0, 0.0]
    sparse = np.c_[rng.uniform(-0.15, 0.15, (100, 2)), np.zeros(100)] + [0.0, 1.0, 0.0]
    image, omega, each = _splat(ctx, np.r_[dense, sparse], 1.0)
    assert float((image * omega).sum()) == pytest.approx(each, rel=1e-4)
    lone, omega, each = _splat(ctx, dense[:1], 1.0)  # one photon alone: the widest kernel the range allows
    assert float((lone * omega).sum()) == pytest.approx(each, rel=1e-4)
    crowded, _, _ = _splat(ctx, dense, 1.0)
    peak = lambda im: float(im.max() / im.sum())  # noqa: E731 (the kernel's peak share: higher is narrower)
    assert peak(crowded) > 3 * peak(lone)


def _frames(seeds, controls: dict | None = None, **changes):
    scene = load_builtin("sphere1")
    params = dataclasses.replace(QUICK, **{"photon_res": 96, "light_res": 128, "width": 64, "height": 64, **changes})
    renderer = Renderer(scene, controls=controls)
    try:
        frames = [renderer.render(scene, dataclasses.replace(params, seed=s)) for s in seeds]
    finally:
        renderer.release()
    return frames, params.resolved(scene)


def test_the_density_pass_is_counted_in_the_frame_cost():
    (frame,), params = _frames([0], splat="density")
    cost = frame_cost(frame.records, params)
    assert cost["density_reads"] == DENSITY_READS * cost["splats"] > 0
    assert cost["total"] == cost["map_reads"] + cost["emission_reads"] + cost["splats"] + cost["density_reads"]


@pytest.mark.slow
def test_ignoring_the_density_scores_worse_on_sphere1():
    """One frame's caustic relMSE against a 32-seed mean of fixed splats at 4× the photons
    (a reference for the kernels' bias and noise at this size), 8 seeds each: the density
    read must beat one width for all (DENSITY_IGNORED) by more than 2 SE."""
    reference_frames, _ = _frames(range(100, 132), photon_res=192)
    stack = np.stack([f.images["caustic"] for f in reference_frames])
    reference, variance = stack.mean(axis=0), stack.var(axis=0, ddof=1) / len(stack)
    used, _ = _frames(range(8), splat="density")
    ignored, _ = _frames(range(8), controls={"DENSITY_IGNORED": 1}, splat="density")
    a = frame_relative_mse(reference, variance, np.stack([f.images["caustic"] for f in used]))
    b = frame_relative_mse(reference, variance, np.stack([f.images["caustic"] for f in ignored]))
    assert b.debiased > a.debiased + 2 * math.hypot(a.standard_error, b.standard_error), (a, b)
