"""The exact replay's Dr.Jit engine (``reference.wavefront``: the emission and every
step on the device) against its numpy twin (``exact_emission``'s records, then
``oracle.advance`` step after step): on every built-in, with both Fresnel modes, the
same medium collisions (photon, step, and the records' float32 end, direction and
power) and the same power budgets. The E images are made from these rows alone, so
equal rows are equal images."""

from __future__ import annotations

import numpy as np
import pytest

from tests.shared import REPLAY_PHOTON_RES, replay_differences
from volcaustics.approx.emission import true_rays
from volcaustics.approx.light import LightFrustum
from volcaustics.reference import replay, wavefront
from volcaustics.reference.oracle import Oracle
from volcaustics.scenes import BUILTIN_NAMES, load_builtin
from volcaustics.scenes.bounds import medium_bounds

PHOTON_RES = REPLAY_PHOTON_RES
STEPS = 512      # the replay's own (measurement.EXACT_STEPS)


def _both(name: str, fresnel: str, beams: bool = False, splits: int = 0, every: int = 1) -> tuple:
    scene = load_builtin(name)
    oracle = Oracle(scene)
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    groups = [(true_rays(scene.light, frustum, PHOTON_RES, seed), seed) for seed in (3, 4, 5)]
    return tuple(replay.exact_replays(scene, groups, steps=STEPS, fresnel=fresnel, oracle=oracle, engine=engine,
                                      beams=beams, splits=splits, slots=PHOTON_RES**2, every=every)
                 for engine in ("numpy", "drjit"))


@pytest.mark.parametrize("name", BUILTIN_NAMES)
@pytest.mark.parametrize("fresnel", ["deterministic", "stochastic", "stratified"])
def test_the_drjit_replay_is_the_numpy_replay(name, fresnel):
    numpy_engine, drjit_engine = _both(name, fresnel)
    assert sum(len(c.rows) for c in numpy_engine) > 100, "too few collisions to compare"
    assert replay_differences(numpy_engine, drjit_engine) == []


@pytest.mark.parametrize("name", ["sphere1", "bunny", "refocus"])
def test_the_drjit_beams_are_the_numpy_beams(name):
    """splat = beams: no free flight, every segment in the medium kept as a beam (start,
    direction, length, power at its start): the same rows from both engines."""
    numpy_engine, drjit_engine = _both(name, "stochastic", beams=True)
    assert numpy_engine[0].rows.dtype == replay.BEAM_ROW_DTYPE
    assert sum(len(c.rows) for c in numpy_engine) > 100, "too few beams to compare"
    assert replay_differences(numpy_engine, drjit_engine) == []


@pytest.mark.parametrize(("beams", "every"), [(False, 1), (True, 1), (True, 3)])
def test_the_drjit_splits_are_the_numpy_splits(beams, every):
    """fresnel_splits (scenes.splitting): the forced choices and the silent segments of
    each batch (and split_every's kept photons) the same in both engines; the three
    batches' photons all there."""
    numpy_engine, drjit_engine = _both("two_spheres", "stratified", beams=beams, splits=2, every=every)
    assert {int(p) // PHOTON_RES**2 for p in numpy_engine[0].rows["photon"]} == {0, 1, 2}
    assert replay_differences(numpy_engine, drjit_engine) == []


def test_free_flights_from_drjits_own_log_are_flagged(monkeypatch):
    """Negative control: Dr.Jit's float32 log differs from numpy's in a quarter of the
    2^24 draws; free flights from it must show in the comparison."""
    import drjit as dr

    from volcaustics.reference.mi_setup import mitsuba

    def own_log(sigma_bar):
        u = np.arange(1 << 24, dtype=np.uint32).astype(np.float32) * np.float32(2.0**-24)
        return -dr.log(mitsuba().Float(np.float32(1.0) - u)).numpy() / np.float32(sigma_bar)

    monkeypatch.setattr(wavefront, "free_flight_table", own_log)
    assert replay_differences(*_both("sphere1", "stochastic")) != []


def test_launches_without_a_photon_that_reaches_glass_are_empty_not_errors():
    """A set of rays with no photon, one with no power, one aimed away from the glass,
    alone or beside rays that hit: the Dr.Jit engine once failed on size-0 arrays
    ("operands have incompatible sizes") where the numpy engine gave empty replays."""
    from volcaustics.approx.emission import EmissionRays

    scene = load_builtin("sphere1")
    oracle = Oracle(scene)
    real = true_rays(scene.light, LightFrustum.for_scene(scene, *medium_bounds(scene)), 16, 1)
    empty = EmissionRays(photon=np.zeros(0, np.uint32), direction=np.zeros((0, 3)), power=np.zeros((0, 3)))
    dark = EmissionRays(photon=real.photon, direction=real.direction, power=np.zeros_like(real.power))
    away = EmissionRays(photon=real.photon, direction=-real.direction, power=real.power)
    for groups in ([(empty, 1)], [(dark, 1)], [(away, 1)], [(dark, 1), (real, 2), (empty, 3)]):
        numpy_engine, drjit_engine = (replay.exact_replays(scene, groups, steps=64, fresnel="stochastic",
                                                           oracle=oracle, engine=engine)
                                      for engine in ("numpy", "drjit"))
        assert replay_differences(numpy_engine, drjit_engine) == []
        assert [c.photons for c in drjit_engine][:1] == [0]
    first = np.zeros(0, replay.RECORD_DTYPE)
    assert [len(c.rows) for c in replay.exact_collisions(scene, [(first, 1)], steps=8, fresnel="stochastic",
                                                          oracle=oracle)] == [0]


def test_the_device_draws_are_scenes_rng_bit_for_bit():
    """``Wavefront.uniform`` (the free flights' and the Fresnel choices' draws) is
    ``scenes.rng.uniform`` on 100,000 random (seed, photon, step, dim), as the GLSL twin
    is (tests/approx/test_rng_glsl.py); a wrong step is flagged (the negative control)."""
    from volcaustics.reference.oracle import ReplayConstants
    from volcaustics.scenes.rng import uniform

    scene = load_builtin("sphere1")
    oracle = Oracle(scene)
    w = wavefront.Wavefront(ReplayConstants(scene, "stochastic"), oracle)
    rng = np.random.default_rng(7)
    seed, photon = (rng.integers(0, 2**32, 100_000, dtype=np.uint64).astype(np.uint32) for _ in range(2))
    for step, dim in ((0, 1), (1, 0), (511, 1)):
        got = w.uniform(w.U32(seed), w.U32(photon), step, dim).numpy()
        assert np.array_equal(got, uniform(seed, photon, step, dim))
    assert not np.array_equal(w.uniform(w.U32(seed), w.U32(photon), 2, 0).numpy(), uniform(seed, photon, 1, 0))
