"""``metrics.flip`` against NVIDIA's ``flip-evaluator``: the same HDR-FLIP error maps,
bit for bit where the powers agree, within a power's last bit everywhere."""

from __future__ import annotations

import sys

import flip_evaluator
import numpy as np
import pytest

from volcaustics.metrics import flip
from volcaustics.metrics.image import hdr_flip, hdr_flip_frames


def _pair(seed=0, height=40, width=56):
    """A non-square HDR reference (a bright spot over a dim gradient, colours differing)
    and noisy tests of it, float32."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width] / max(height, width)
    spot = np.exp(-((x - 0.35) ** 2 + (y - 0.45) ** 2) / 0.01)
    r = np.stack([0.05 + 0.1 * x, 0.04 + 0.05 * y, 0.03 + 0.02 * x * y], axis=2) + spot[..., None] * [40.0, 25.0, 9.0]
    tests = np.clip(r * (1 + 0.3 * rng.standard_normal((3,) + r.shape)), 0, None)
    return r.astype(np.float32), tests.astype(np.float32)


def _library(r, t, start, stop):
    error, _, used = flip_evaluator.evaluate(r, t, "HDR", applyMagma=False, computeMeanError=False,
                                             parameters={"startExposure": start, "stopExposure": stop, "ppd": 67.0})
    return np.asarray(error, np.float32).reshape(r.shape[:2]), used


def test_maps_match_the_library():
    """Every pixel but those where a float32 power rounds differently is identical. Here
    the powers are correctly rounded, glibc's ``powf`` within 0.82 ulp: such a pixel moves
    by one ulp (6e-8 relative) of a power, at most 116 · 6e-8 = 7e-6 in L* (the cube root
    of Y), which the 0.7 power's slope 0.7 · D^-0.3 raises to ≲ 1e-4 of FLIP's [0, 1] for a
    distance D ≥ 1e-3; the mean over the pixels moves far less (a few such pixels)."""
    r, tests = _pair()
    start, stop = -4.3, 1.2
    ours = flip.hdr_flip_maps(r, tests, start_exposure=start, stop_exposure=stop)
    for t, mine in zip(tests, ours):
        theirs, used = _library(r, t, start, stop)
        assert used["numExposures"] == len(flip.exposures(start, stop))
        assert np.mean(mine == theirs) >= 0.99
        assert np.max(np.abs(mine.astype(np.float64) - theirs)) <= 1e-4
        assert abs(float(np.mean(mine, dtype=np.float64)) - float(np.mean(theirs, dtype=np.float64))) <= 1e-6


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the library's powf is glibc's")
def test_with_the_c_librarys_powf_the_maps_are_identical(monkeypatch):
    """The port is the library's computation step for step: with the C library's ``powf``
    in place of the correctly rounded power, every pixel is bit-identical."""
    pow_each = np.frompyfunc(lambda x, y: flip.LIBM.powf(x, y), 2, 1)
    monkeypatch.setattr(flip, "_powf", lambda x, y: np.asarray(
        pow_each(x, np.broadcast_to(np.float32(y), np.shape(x))), np.float32))
    r, tests = _pair(1, 24, 20)
    ours = flip.hdr_flip_maps(r, tests[:1], start_exposure=-3.0, stop_exposure=0.5)
    np.testing.assert_array_equal(ours[0], _library(r, tests[0], -3.0, 0.5)[0])


def test_frames_at_once_equal_one_at_a_time():
    r, tests = _pair(2)
    keep = np.ones(r.shape[:2], bool)
    keep[:, :5] = False
    together = hdr_flip_frames(r, tests, mask=keep, full=True)
    for t, one in zip(tests, together):
        alone = hdr_flip(r, t, mask=keep, full=True)
        assert alone["value"] == one["value"] and alone["num_exposures"] == one["num_exposures"]
        np.testing.assert_array_equal(alone["map"], one["map"])


def test_filters_are_flips():
    """FLIP's filter sizes at 67 pixels per degree: the CSF's radius from its widest
    Gaussian (b = 0.04), the feature filter's 3σ, σ = 0.5 · 0.082 · ppd; normalised."""
    ycx, cz = flip.spatial_filters(67.0)
    feature = flip.feature_filter(67.0)
    assert len(ycx) == len(cz) == 2 * 10 + 1 and len(feature) == 2 * 9 + 1
    np.testing.assert_allclose(ycx.sum(axis=0), 1.0, rtol=1e-6)
    np.testing.assert_allclose(feature[:, 0].sum(), 1.0, rtol=1e-6)
    assert feature[:, 1].sum() == pytest.approx(0.0, abs=1e-6)
    with pytest.raises(ValueError, match="T×H×W×3"):
        flip.hdr_flip_maps(np.zeros((4, 4, 3)), np.zeros((4, 4, 3)), start_exposure=0.0, stop_exposure=1.0)
