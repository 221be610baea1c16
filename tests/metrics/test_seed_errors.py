"""metrics.noise over the approximation's seeds: the debiased relative MSE of S frames
against a noisy reference (constructed cases, an unbiasedness check with known noise,
the Gram-matrix bootstrap against explicit resamples), the bootstrap interval of a
per-seed metric, and the reference's noisy copy."""

from __future__ import annotations

import numpy as np
import pytest

from metrics.noise import _bootstrap_weights, noisy_copy, seed_mean_interval, seed_relative_mse

H, W = 32, 32


def _truth():
    """A smooth positive image (H×W×3, linear), well above 0 everywhere."""
    y, x = np.mgrid[0:H, 0:W]
    blob = np.exp(-((x - 12.0) ** 2 + (y - 18.0) ** 2) / 60.0)
    return np.stack([0.5 + blob, 0.4 + 0.8 * blob, 0.3 + 0.5 * blob], axis=-1)


def _brute_force(reference, reference_var, frames):
    """The debiased relative MSE straight from its definition (SeedError's docstring),
    with the seeds' sample variance computed by numpy over the frames themselves."""
    energy = np.sum(reference**2)
    raw = np.sum((frames.mean(axis=0) - reference) ** 2) / energy
    noise = np.sum(frames.var(axis=0, ddof=1)) / len(frames) / energy
    return raw - np.sum(reference_var) / energy - noise


# --- seed_relative_mse ---------------------------------------------------------------


def test_frames_equal_to_the_reference_have_zero_error():
    r = _truth()
    result = seed_relative_mse(r, np.zeros_like(r), np.stack([r] * 6), resamples=200)
    assert result.raw == 0.0 and result.reference_floor == 0.0
    assert result.approx_noise == 0.0 and result.debiased == 0.0
    assert result.interval == (0.0, 0.0)
    assert result.seeds == 6 and result.resamples == 200 and result.pixels == H * W


def test_a_constant_bias_on_identical_seeds():
    """Every frame is R + b: raw = Σ b² / Σ R², no spread over seeds, and the
    reference's floor Σ var / Σ R² is subtracted; every resample is the same."""
    rng = np.random.default_rng(20)
    r, b = _truth(), 0.03
    var = rng.uniform(0.0, 2e-4, r.shape)
    result = seed_relative_mse(r, var, np.stack([r + b] * 5), resamples=300)
    energy = np.sum(r**2)
    raw, floor = r.size * b**2 / energy, var.sum() / energy
    assert result.raw == pytest.approx(raw, rel=1e-12)
    assert result.reference_floor == pytest.approx(floor, rel=1e-12)
    assert result.approx_noise == pytest.approx(0.0, abs=1e-12 * raw)
    assert result.debiased == pytest.approx(raw - floor, rel=1e-9)
    assert result.interval == pytest.approx((raw - floor, raw - floor), rel=1e-9)


def test_one_seed_has_no_noise_estimate_and_no_interval():
    rng = np.random.default_rng(21)
    r = _truth()
    var = np.full_like(r, 1e-4)
    frame = r * 1.02 + 0.01 * rng.standard_normal(r.shape)
    result = seed_relative_mse(r, var, frame[None])
    energy = np.sum(r**2)
    assert np.isnan(result.approx_noise)
    assert result.interval is None and result.resamples == 0 and result.seeds == 1
    assert result.raw == pytest.approx(np.sum((frame - r) ** 2) / energy, rel=1e-12)
    assert result.debiased == pytest.approx(result.raw - var.sum() / energy, rel=1e-12)


def _biased_frames(rng, s=8, sigma=0.05, ref_sd=0.01):
    """Frames R(1 + δ) + N(0, σ²) for ``s`` seeds, δ varying over the image, and a
    reference R + N(0, ref_sd²) with its variance: (reference, var, frames, m = R δ)."""
    truth = _truth()
    y, x = np.mgrid[0:H, 0:W]
    delta = (0.04 + 0.03 * np.sin(x / 5.0) * np.cos(y / 7.0))[..., None]
    reference = truth + ref_sd * rng.standard_normal(truth.shape)
    var = np.full_like(truth, ref_sd**2)
    frames = truth * (1 + delta) + sigma * rng.standard_normal((s, *truth.shape))
    return reference, var, frames, truth * delta


def test_debiased_error_is_the_bias_alone():
    """Frames R(1 + δ) + N(0, σ²) for S = 8 seeds against a reference R + N(0, v_R)
    whose variance v_R is given: the debiased relMSE estimates Σ(R δ)² / Σ R_given².

    Tolerance from the noise: with m = R δ per value and v = σ²/S + v_R the variance
    of the mean's difference, Σ(Ā − R)² has the variance Σ(4 m² v + 2 v²); the seeds'
    Σ s²/S (independent of the mean for Gaussian noise) adds Σ 2 σ⁴ / (S² (S − 1)).
    Five of those standard deviations, over Σ R²."""
    s, sigma, ref_sd = 8, 0.05, 0.01
    reference, var, frames, m = _biased_frames(np.random.default_rng(22), s, sigma, ref_sd)
    result = seed_relative_mse(reference, var, frames, resamples=100)

    energy = np.sum(reference**2)
    v = sigma**2 / s + ref_sd**2
    sd = np.sqrt(np.sum(4 * m**2 * v + 2 * v**2) + m.size * 2 * sigma**4 / (s**2 * (s - 1))) / energy
    assert result.debiased == pytest.approx(np.sum(m**2) / energy, abs=5 * sd)
    # the noise is a large part of the raw error: without debiasing the test above would fail
    assert result.raw - np.sum(m**2) / energy > 20 * sd
    # the noise terms are what they should be (the seeds' within 5 SDs of a variance from 7 dof, per value)
    assert result.reference_floor == pytest.approx(var.sum() / energy, rel=1e-12)
    assert result.approx_noise == pytest.approx(m.size * sigma**2 / s / energy, rel=5 * np.sqrt(2 / (7 * m.size)))
    assert result.debiased == pytest.approx(_brute_force(reference, var, frames), rel=1e-10)


def test_bootstrap_interval_is_deterministic_and_holds_the_estimate():
    reference, var, frames, _ = _biased_frames(np.random.default_rng(22))
    result = seed_relative_mse(reference, var, frames, resamples=500)
    assert seed_relative_mse(reference, var, frames, resamples=500).interval == result.interval
    assert seed_relative_mse(reference, var, frames, resamples=500, seed=1).interval != result.interval
    assert result.level == 0.95 and result.resamples == 500
    lo, hi = result.interval
    assert lo < result.debiased < hi, (result.interval, result.debiased, result.approx_noise)


def test_bootstrap_interval_covers_the_bias():
    """Over 40 independent draws of the case above, the 95% interval must hold the
    true Σ(R δ)² / Σ R² in most of them. A percentile bootstrap over only 8 seeds
    may undercover (its spread lacks the factor √(S/(S − 1)), and its quantiles are
    normal rather than t ones), so ≥ 30 of 40 (75%) is a safe floor: even at an 88%
    rate per draw, fewer than 30 has a probability of ~1%. (Percentile intervals of
    this case recentred on the estimate held the truth in 400 of 400 draws.)"""
    covered = 0
    for seed in range(40):
        reference, var, frames, m = _biased_frames(np.random.default_rng(200 + seed))
        lo, hi = seed_relative_mse(reference, var, frames, resamples=400).interval
        covered += lo <= np.sum(m**2) / np.sum(reference**2) <= hi
    assert covered >= 30, f"the 95% interval held the true bias in {covered} of 40 draws"


@pytest.mark.parametrize("level", [0.5, 0.9])
def test_bootstrap_matches_explicit_resamples(level):
    """The Gram-matrix shortcut against resampled frame stacks built explicitly from
    the same multiplicities, their mean and sample variance computed by numpy."""
    rng = np.random.default_rng(23)
    r = _truth()
    var = rng.uniform(0.0, 1e-4, r.shape)
    s, resamples, seed = 5, 9, 3
    frames = r * 1.03 + 0.05 * rng.standard_normal((s, *r.shape))
    weights = _bootstrap_weights(s, resamples, seed)
    assert weights.shape == (resamples, s) and np.all(weights.sum(axis=1) == s)
    values = [_brute_force(r, var, np.repeat(frames, w.astype(int), axis=0)) for w in weights]
    result = seed_relative_mse(r, var, frames, resamples=resamples, level=level, seed=seed)
    # the interval is bias-corrected: the percentiles shifted by (estimate − mean of the resamples)
    shift = _brute_force(r, var, frames) - np.mean(values)
    expected = np.percentile(values, [50 * (1 - level), 50 * (1 + level)]) + shift
    assert result.interval == pytest.approx(tuple(expected), rel=1e-9)
    assert result.debiased == pytest.approx(_brute_force(r, var, frames), rel=1e-10)


def test_bootstrap_weights_are_deterministic_multiplicities():
    a, b = _bootstrap_weights(6, 50, 7), _bootstrap_weights(6, 50, 7)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, _bootstrap_weights(6, 50, 8))
    assert np.all(a >= 0) and np.all(a == np.round(a)) and np.all(a.sum(axis=1) == 6)


def test_mask_selects_the_pixels():
    rng = np.random.default_rng(24)
    r = _truth()
    var = np.full_like(r, 1e-4)
    frames = r * 1.02 + 0.02 * rng.standard_normal((4, *r.shape))
    mask = np.ones((H, W), bool)
    mask[:, :6] = False
    garbage = frames.copy()
    garbage[:, :, :6] += 10.0
    masked = seed_relative_mse(r, var, garbage, mask=mask, resamples=100)
    assert masked == seed_relative_mse(r, var, frames, mask=mask, resamples=100)
    assert masked.pixels == int(mask.sum())
    assert masked.debiased == pytest.approx(_brute_force(r[mask], var[mask], frames[:, mask]), rel=1e-10)


@pytest.mark.parametrize("bad", ["frame_shape", "var_shape", "no_frame", "zero_reference", "level"])
def test_seed_relative_mse_bad_input(bad):
    r = _truth()
    var, frames, kwargs = np.zeros_like(r), np.stack([r] * 3), {}
    if bad == "frame_shape":
        frames = frames[:, :-1]
    elif bad == "var_shape":
        var = var[..., :2]
    elif bad == "no_frame":
        frames = frames[:0]
    elif bad == "zero_reference":
        r = np.zeros_like(r)
    else:
        kwargs["level"] = 1.0
    with pytest.raises(ValueError):
        seed_relative_mse(r, var, frames, **kwargs)


# --- seed_mean_interval --------------------------------------------------------------


def test_seed_mean_interval():
    values = [0.11, 0.14, 0.09, 0.30, 0.12, 0.10]
    result = seed_mean_interval(values, resamples=500, seed=4)
    assert result["mean"] == pytest.approx(np.mean(values), rel=1e-12)
    lo, hi = result["interval"]
    assert min(values) <= lo < result["mean"] < hi <= max(values)
    assert seed_mean_interval(values, resamples=500, seed=4) == result
    assert result["seeds"] == 6 and result["resamples"] == 500 and result["level"] == 0.95
    # the interval is the percentiles of means of explicit resamples with the same multiplicities
    weights = _bootstrap_weights(6, 500, 4)
    means = [np.repeat(values, w.astype(int)).mean() for w in weights]
    assert (lo, hi) == pytest.approx(tuple(np.percentile(means, [2.5, 97.5])), rel=1e-12)


def test_seed_mean_interval_of_one_value():
    result = seed_mean_interval([0.25])
    assert result["mean"] == 0.25 and result["interval"] is None and result["resamples"] == 0


@pytest.mark.parametrize("values", [[0.1, np.nan, 0.2], [0.1, np.inf], []])
def test_seed_mean_interval_rejects_missing_values(values):
    with pytest.raises(ValueError):
        seed_mean_interval(values)


# --- noisy_copy ----------------------------------------------------------------------


def test_noisy_copy_is_deterministic_and_nonnegative():
    rng = np.random.default_rng(25)
    r = rng.uniform(0.0, 0.1, (H, W, 3))
    var = np.full_like(r, 0.2**2)  # noise far above the values: many would be negative unclipped
    a = noisy_copy(r, var, seed=3)
    np.testing.assert_array_equal(a, noisy_copy(r, var, seed=3))
    assert not np.array_equal(a, noisy_copy(r, var, seed=4))
    assert a.shape == r.shape and a.dtype == np.float32
    assert np.all(a >= 0) and np.mean(a == 0) > 0.2
    np.testing.assert_array_equal(noisy_copy(r, np.zeros_like(r)), r.astype(np.float32))


def test_noisy_copy_has_the_reference_variance():
    """Two halves, R = 1 with variance 0.01 and R = 2 with variance 0.04 (both 10 σ
    above 0, so the clip never acts): the empirical variance of copy − R in each half
    matches. 128×256×3 ≈ 98k values per half: a sample variance's relative standard
    deviation is √(2/n) ≈ 0.45%, so 3% is over 6 of them; the mean is within 5 σ/√n."""
    r = np.ones((256, 256, 3))
    r[:, 128:] = 2.0
    var = np.full_like(r, 0.01)
    var[:, 128:] = 0.04
    diff = noisy_copy(r, var, seed=5).astype(np.float64) - r
    for half in (np.s_[:, :128], np.s_[:, 128:]):
        d, v = diff[half].ravel(), var[half].ravel()[0]
        assert d.var() == pytest.approx(v, rel=0.03)
        assert abs(d.mean()) < 5 * np.sqrt(v / d.size)


def test_noisy_copy_bad_input():
    r = _truth()
    with pytest.raises(ValueError):
        noisy_copy(r, -np.ones_like(r))
    with pytest.raises(ValueError):
        noisy_copy(r, np.ones_like(r)[:-1])
