"""The approximation in a heterogeneous medium (approx.medium_volumes, common/density.glsl):
its delta tracking draws free flights whose optical depths are exponential (a property of
the tracker that needs no other renderer), with negative controls that must fail it (a
tracker that ignores the grid, majorants below the density); a grid of ones renders the
homogeneous frame."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from tests.shared import make_scene, sphere_spec
from volcaustics.approx import ApproxParams, Renderer
from volcaustics.scenes.bounds import box_exit, medium_bounds
from volcaustics.scenes.density import Density
from volcaustics.scenes.medium_grid import density_grid
from volcaustics.scenes.model import Medium, Phase

PARAMS = ApproxParams(photon_res=96, light_res=256, width=48, height=48, steps=3, fog_steps=32, splat_radius=0.03)
PLUME = Density(field="plume", params=(("center", (0.0, 0.0, 0.0)), ("density", 4.0), ("frequency", 2.0),
                                       ("height", 2.6), ("radius", 0.6), ("seed", 3)), resolution=(24, 24, 24))


def _scene(density=PLUME, sigma=(0.5, 0.4, 0.3)):
    base = make_scene([(sphere_spec(0.4, (0.0, 1.6, 0.0), 24), 1.5, (0, 0, 0))], cutoff=25.0)
    return dataclasses.replace(base, medium=Medium(sigma, (0.05,) * 3, Phase(), density))


def _depths(scene, records, n=401) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(τ to the collision or nan, τ to the box's end, collided) of the medium segments: τ is
    sigma_bar·∫ρ by the trapezoid rule on n points (ρ is piecewise trilinear: O(1/n²))."""
    grid = density_grid(scene)
    lo, hi = medium_bounds(scene)
    rate = np.float32(scene.medium.sigma_bar)
    start, direction = records["start"].astype(np.float64), records["direction"].astype(np.float64)
    span = box_exit(start, direction, lo, hi)
    length = records["max_length"].astype(np.float64)
    collided = length <= span
    t = np.linspace(0.0, 1.0, n)

    def depth(lengths):
        out = np.empty(len(lengths))
        for i in range(0, len(lengths), 256):
            s = lengths[i:i + 256, None] * t
            points = start[i:i + 256, None] + s[..., None] * direction[i:i + 256, None]
            out[i:i + 256] = np.trapezoid(grid.eval(points.reshape(-1, 3)).reshape(s.shape), s, axis=1)
        return out * rate

    return np.where(collided, depth(np.minimum(length, span)), np.nan), depth(span), collided


def _flights_are_exponential(scene, controls=None, seeds=(0,)) -> tuple[bool, dict]:
    """Whether the medium segments' optical depths to their collisions are Exp(1): the
    censored ones (no collision before the box's end) as many as Σ exp(−τ_end) within 4 SE,
    and the collided ones' (1 − e^{−τ})/(1 − e^{−τ_end}) uniform (mean within 4 SE, KS p > 1e-4)."""
    renderer = Renderer(scene, controls=controls)
    try:
        records = np.concatenate([r[r["inside"] < 0] for seed in seeds
                                  for r in renderer.render(scene, dataclasses.replace(PARAMS, seed=seed)).records])
    finally:
        renderer.release()
    tau, tau_end, collided = _depths(scene, records)
    q = np.exp(-tau_end)
    censored_z = ((~collided).sum() - q.sum()) / math.sqrt((q * (1 - q)).sum())
    v = (1.0 - np.exp(-tau[collided])) / (1.0 - q[collided])
    mean_z = (v.mean() - 0.5) / math.sqrt(1.0 / 12.0 / len(v))
    ks = stats.kstest(v, "uniform").pvalue
    found = {"segments": len(records), "collided": int(collided.sum()), "censored_z": censored_z, "mean_z": mean_z,
             "ks_p": ks}
    return abs(censored_z) <= 4.0 and abs(mean_z) <= 4.0 and ks > 1e-4, found  # 4 SE: false alarm ~1e-4


def test_delta_tracking_draws_exponential_optical_depths():
    ok, found = _flights_are_exponential(_scene())
    print("delta tracking", found)
    assert ok, found
    assert found["collided"] > 1000 and found["segments"] - found["collided"] > 1000  # both outcomes tested


@pytest.mark.parametrize("controls", [{"GRID_IGNORED": 1}, {"MAJORANT_SCALE": "0.25"}],
                         ids=["grid ignored", "majorant below density"])
def test_a_wrong_tracker_is_caught(controls):
    ok, found = _flights_are_exponential(_scene(), controls)
    print("wrong tracker", controls, found)
    assert not ok, found


def test_a_grid_of_ones_renders_the_homogeneous_frame():
    """ρ ≡ 1 on a grid: fog and direct light as the homogeneous medium's, to the volumes'
    interpolation (a constant's march is exact: 2e-3 measured, 1e-2 allowed); the caustic's
    total within its noise over seeds (the flights draw other numbers)."""
    ones = Density(field="box", params=(("inside", 1.0), ("outside", 1.0)), resolution=(4, 4, 4))
    grey = (0.3, 0.3, 0.3)
    het, hom = _scene(ones, grey), _scene(None, grey)
    frames = {}
    for name, scene in (("het", het), ("hom", hom)):
        renderer = Renderer(scene)
        try:
            frames[name] = [renderer.render(scene, dataclasses.replace(PARAMS, seed=s), keep_records=False).images
                            for s in range(6)]
        finally:
            renderer.release()
    for layer in ("fog", "direct"):
        a, b = frames["het"][0][layer], frames["hom"][0][layer]
        assert np.abs(a - b).sum() <= 1e-2 * np.abs(b).sum(), layer
    totals = {k: np.array([f["caustic"].sum() for f in v]) for k, v in frames.items()}
    se = math.sqrt(totals["het"].var(ddof=1) / 6 + totals["hom"].var(ddof=1) / 6)
    assert abs(totals["het"].mean() - totals["hom"].mean()) <= 4.0 * se, totals
    # negative control: a grid of 1.2 is seen in the fog
    denser = _scene(dataclasses.replace(ones, params=(("inside", 1.2), ("outside", 1.2))), grey)
    renderer = Renderer(denser)
    try:
        fog = renderer.render(denser, PARAMS, keep_records=False).images["fog"]
    finally:
        renderer.release()
    assert np.abs(fog - frames["hom"][0]["fog"]).sum() > 1e-2 * np.abs(frames["hom"][0]["fog"]).sum()
