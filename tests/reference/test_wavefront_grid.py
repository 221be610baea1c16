"""The exact replay's Dr.Jit engine through a density grid (``reference.wavefront_grid``)
against its numpy twins: ρ and the optical depth bit for bit, delta tracking to float64
rounding of Dr.Jit's ``log``, and whole replays (points and beams) on the media scenes row
for row, as ``tests/reference/test_wavefront.py`` holds the homogeneous ones."""

from __future__ import annotations

import numpy as np
import pytest

from tests.shared import REPLAY_PHOTON_RES, media_scene, replay_differences
from volcaustics.approx.emission import true_rays
from volcaustics.approx.light import LightFrustum
from volcaustics.experiment.measurement import EXACT_STEPS
from volcaustics.reference import replay
from volcaustics.reference.oracle import Oracle, ReplayConstants
from volcaustics.reference.wavefront import Wavefront
from volcaustics.scenes import tracking
from volcaustics.scenes.bounds import medium_bounds

MEDIA = ("fogbank", "smoke", "layered_fog")


@pytest.fixture(scope="module")
def smoke():
    scene = media_scene("smoke")
    constants = ReplayConstants(scene, "stochastic")
    return constants, Wavefront(constants, Oracle(scene))


def _v(w, a: np.ndarray):
    """An N×3 numpy array as the wavefront's 3-vector of float64."""
    return w.V64(*(w.F64(np.ascontiguousarray(a[:, k])) for k in range(3)))


def _segments(grid, n: int = 20_000, seed: int = 1) -> tuple:
    """Random segments around the grid's box (a tenth of it beyond each face), 50 of them
    parallel to a face."""
    rng = np.random.default_rng(seed)
    o = grid.lo + (rng.random((n, 3)) * 1.2 - 0.1) * (grid.hi - grid.lo)
    d = rng.normal(size=(n, 3))
    d[:50, 1] = 0.0
    return o, d / np.linalg.norm(d, axis=1)[:, None], rng.random(n) * 3.0


def test_density_and_optical_depth_are_the_numpy_twins_bit_for_bit(smoke):
    constants, w = smoke
    o, d, length = _segments(constants.grid)
    assert np.array_equal(w.grid.eval(_v(w, o)).numpy(), constants.grid.eval(o))
    depth = w.grid.optical_depth(_v(w, o), _v(w, d), w.F64(length)).numpy()
    want = tracking.optical_depth(constants.grid, o, d, length)
    assert (want > 0).sum() > 5_000, "too few segments through the smoke to compare"
    assert np.array_equal(depth, want)


def test_a_division_by_a_literal_is_flagged(smoke, monkeypatch):
    """Negative control: Dr.Jit turns x / literal into x · (1 / literal); ρ computed so is
    not numpy's in the last bit, and the comparison above sees it."""
    constants, w = smoke
    o, _, _ = _segments(constants.grid)
    monkeypatch.setattr(w.grid, "_opaque", lambda value: value)
    assert not np.array_equal(w.grid.eval(_v(w, o)).numpy(), constants.grid.eval(o))


def test_delta_tracking_draws_the_numpy_collisions(smoke):
    """The same first collisions; a distance may differ in the last float64 bit (Dr.Jit's
    log), never more, and a wrong step's draws are flagged."""
    import drjit as dr

    constants, w = smoke
    o, d, length = _segments(constants.grid)
    seed, photon = np.full(len(o), 5, np.uint32), np.arange(len(o), dtype=np.uint32)
    want = tracking.delta_track(constants.grid, o, d, length, constants.sigma_bar, seed, photon, 3)

    def tracked(step):
        return w.grid.delta_track(_v(w, o), _v(w, d), w.F64(length), constants.sigma_bar,
                                  w.U32(seed), w.U32(photon), dr.opaque(w.U32, step)).numpy()

    got = tracked(3)
    assert (want >= 0).sum() > 100, "too few collisions to compare"
    assert np.array_equal(got >= 0, want >= 0)
    assert np.allclose(got, want, rtol=1e-15, atol=0.0)
    assert not np.array_equal(tracked(4) >= 0, want >= 0)


@pytest.mark.parametrize("name", MEDIA)
@pytest.mark.parametrize("beams", [False, True])
def test_the_drjit_replay_of_a_grid_is_the_numpy_replay(name, beams):
    scene = media_scene(name)
    oracle = Oracle(scene)
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    groups = [(true_rays(scene.light, frustum, REPLAY_PHOTON_RES, seed), seed) for seed in (3, 4, 5)]
    numpy_engine, drjit_engine = (replay.exact_replays(scene, groups, steps=EXACT_STEPS, fresnel="stochastic",
                                                       oracle=oracle, engine=engine, beams=beams)
                                  for engine in ("numpy", "drjit"))
    assert sum(len(c.rows) for c in numpy_engine) > 100, "too few collisions to compare"
    assert replay_differences(numpy_engine, drjit_engine) == []
