"""metrics.noise on synthetic batch images whose truth is known: noise of known
variance around a known image, with and without a known bias, Gaussian and
skewed (photon counts)."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.metrics.noise import batch_energy_ratio, debiased_relative_mse, noise_floor

H, W, K, L = 24, 32, 16, 8


def _truth(rng):
    y, x = np.mgrid[0:H, 0:W]
    blob = np.exp(-((x - 14.0) ** 2 + (y - 10.0) ** 2) / 40.0)
    return np.stack([blob, 0.5 * blob, 0.2 + 0 * blob], axis=-1) + 0.05 * rng.random((H, W, 3))


def _gaussian(rng, mean, sd, n):
    """n batches whose mean has standard deviation ``sd`` per pixel."""
    return mean + sd * np.sqrt(n) * rng.standard_normal((n, *mean.shape))


def _photons(rng, mean, n, count=1.0):
    """n batches of photon-like noise: Poisson(count) photons per pixel and batch, each
    carrying mean/count (unbiased for ``mean``; skewed, mostly 0 or 1 photon)."""
    return mean / count * rng.poisson(count, (n, *mean.shape))


def _z_scores(rng, draw, count=200):
    return np.array([debiased_relative_mse(*draw(rng)).z for _ in range(count)])


@pytest.mark.parametrize("kind", ["gaussian", "photons"])
def test_unbiased_estimates_are_explained_by_noise(kind):
    """Over many draws the debiased error has mean ≈ 0 and z-scores of unit spread,
    for Gaussian noise and for skewed photon counts (≈ 1 photon per pixel and batch)."""
    rng = np.random.default_rng(1)
    truth = _truth(rng)
    if kind == "gaussian":
        def draw(rng):
            return _gaussian(rng, truth, 0.01, L), _gaussian(rng, truth, 0.02, K)
    else:
        def draw(rng):
            return _photons(rng, truth, L), _photons(rng, truth, K, 2.0)
    z = _z_scores(rng, draw)
    assert abs(z.mean()) < 0.25  # 200 draws: the mean of unit-variance z has sd 0.07
    assert 0.8 < z.std() < 1.25
    assert np.all(np.abs(z) < 5)


def test_noise_term_is_the_sum_of_both_variances():
    rng = np.random.default_rng(2)
    truth = _truth(rng)
    results = [debiased_relative_mse(_gaussian(rng, truth, 0.01, L), _gaussian(rng, truth, 0.02, K))
               for _ in range(50)]
    energy = float(np.sum(truth**2))
    assert np.mean([r.test_noise for r in results]) == pytest.approx(0.02**2 * truth.size / energy, rel=0.03)
    assert np.mean([r.reference_noise for r in results]) == pytest.approx(0.01**2 * truth.size / energy, rel=0.05)


def test_a_bias_is_measured_and_flagged():
    rng = np.random.default_rng(3)
    truth = _truth(rng)
    result = debiased_relative_mse(_gaussian(rng, truth, 0.01, L), _gaussian(rng, truth * 1.05, 0.02, K))
    # bias² relative to the reference energy: 0.05² for a proportional bias
    assert result.debiased == pytest.approx(0.05**2, abs=4 * result.standard_error)
    assert result.z > 5
    assert result.raw == pytest.approx(result.debiased + result.noise)


def test_error_of_an_image_with_itself_is_zero():
    rng = np.random.default_rng(4)
    truth = _truth(rng)
    same = np.stack([truth] * 4)
    result = debiased_relative_mse(same, same)
    assert result.raw == 0 and result.noise == 0 and result.debiased == 0 and result.z == 0
    assert noise_floor(truth, np.zeros_like(truth)) == 0
    np.testing.assert_allclose(batch_energy_ratio(same, same).ratio, 1.0)


def test_mask_selects_pixels():
    rng = np.random.default_rng(5)
    truth = _truth(rng)
    reference, test = _gaussian(rng, truth, 0.01, L), _gaussian(rng, truth, 0.02, K)
    test[:, :, :4] += 10.0  # garbage in the masked-out columns
    mask = np.ones((H, W), bool)
    mask[:, :4] = False
    assert abs(debiased_relative_mse(reference, test, mask=mask).z) < 4
    assert debiased_relative_mse(reference, test).z > 100
    mean, var = reference.mean(0), reference.var(0, ddof=1) / L
    assert noise_floor(mean, var, mask=mask) == pytest.approx(var[mask].sum() / (mean[mask] ** 2).sum())


def test_energy_ratio_and_its_standard_error():
    rng = np.random.default_rng(6)
    truth = _truth(rng)
    draws = [batch_energy_ratio(_gaussian(rng, truth, 0.01, L), _gaussian(rng, truth * 1.02, 0.02, K))
             for _ in range(300)]
    ratios = np.array([e.ratio for e in draws])
    errors = np.array([e.standard_error for e in draws])
    np.testing.assert_allclose(ratios.mean(0), 1.02, rtol=1e-3)
    # the stated standard error is the spread of the ratio over draws
    np.testing.assert_allclose(errors.mean(0), ratios.std(0), rtol=0.15)


def test_energy_ratio_counts_pixels_that_share_a_sample():
    """A test image whose noise is one shared factor per batch (all pixels move
    together): the batches' totals see the full variance of the total, which a sum
    of per-pixel variances would understate by the number of pixels."""
    rng = np.random.default_rng(7)
    truth = _truth(rng)
    shared = truth[None] * (1 + 0.1 * rng.standard_normal((K, 1, 1, 1)))
    e = batch_energy_ratio(np.stack([truth] * L), shared)
    per_pixel = shared.var(0, ddof=1).sum((0, 1)) / K
    assert np.all(e.test_total_var > 100 * per_pixel)


@pytest.mark.parametrize("bad", ["shape", "batches", "zero", "mask"])
def test_bad_input_raises_value_error(bad):
    rng = np.random.default_rng(8)
    truth = _truth(rng)
    reference, test, kwargs = _gaussian(rng, truth, 0.01, L), _gaussian(rng, truth, 0.02, K), {}
    if bad == "shape":
        test = test[:, :-1]
    elif bad == "batches":
        test = test[:3]
    elif bad == "zero":
        reference = np.zeros_like(reference)
    else:
        kwargs["mask"] = np.ones((H + 1, W), bool)
    with pytest.raises(ValueError):
        debiased_relative_mse(reference, test, **kwargs)
    with pytest.raises(ValueError):
        batch_energy_ratio(reference, test, **kwargs)
    with pytest.raises(ValueError):
        noise_floor(reference[0], -np.ones_like(reference[0]))
