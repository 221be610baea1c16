"""metrics.noise over the approximation's seeds: the debiased relative MSE of S frames
against a noisy reference (constructed cases, identities against its definition,
the jackknife standard error against an explicit delete-one computation, the
calibration of its Student-t interval and standard error over many simulated
draws), the bootstrap interval of a per-seed metric, and the reference's noisy
copy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import t as student_t

from volcaustics.metrics.noise import (
    MIN_SEEDS_FOR_INTERVAL,
    bootstrap_weights,
    noisy_copy,
    seed_mean_interval,
    seed_relative_mse,
)

H, W = 32, 32


def _truth():
    """A smooth positive image (H×W×3, linear), well above 0 everywhere."""
    y, x = np.mgrid[0:H, 0:W]
    blob = np.exp(-((x - 12.0) ** 2 + (y - 18.0) ** 2) / 60.0)
    return np.stack([0.5 + blob, 0.4 + 0.8 * blob, 0.3 + 0.5 * blob], axis=-1)


def _delta():
    """A relative bias that varies over the image (H×W×1): 4% ± 3%."""
    y, x = np.mgrid[0:H, 0:W]
    return (0.04 + 0.03 * np.sin(x / 5.0) * np.cos(y / 7.0))[..., None]


def _brute_force(reference, reference_var, frames):
    """The debiased relative MSE straight from its definition (SeedsRelMSE's docstring),
    with the seeds' sample variance computed by numpy over the frames themselves."""
    energy = np.sum(reference**2)
    raw = np.sum((frames.mean(axis=0) - reference) ** 2) / energy
    noise = np.sum(frames.var(axis=0, ddof=1)) / len(frames) / energy
    return raw - np.sum(reference_var) / energy - noise


def _biased_frames(rng, s=8, sigma=0.05, ref_sd=0.01):
    """Frames R(1 + δ) + N(0, σ²) for ``s`` seeds and a reference R + N(0, ref_sd²)
    with its variance: (reference, var, frames, m = R δ)."""
    truth = _truth()
    reference = truth + ref_sd * rng.standard_normal(truth.shape)
    var = np.full_like(truth, ref_sd**2)
    frames = truth * (1 + _delta()) + sigma * rng.standard_normal((s, *truth.shape))
    return reference, var, frames, truth * _delta()


# --- seed_relative_mse: constructed cases ------------------------------------------


def test_frames_equal_to_the_reference_have_zero_error():
    r = _truth()
    result = seed_relative_mse(r, np.zeros_like(r), np.stack([r] * 6))
    assert result.raw == 0.0 and result.reference_floor == 0.0
    assert result.approx_noise == 0.0 and result.debiased == 0.0
    assert result.standard_error == 0.0 and result.interval == (0.0, 0.0)
    assert result.seeds == 6 and result.level == 0.95 and result.pixels == H * W


def test_a_constant_bias_on_identical_seeds():
    """Every frame is R + b: raw = Σ b² / Σ R², no spread over seeds (the jackknife
    part is 0), the reference's floor Σ var / Σ R² is subtracted, and the standard
    error is R's part alone, √Σ(4 b̂² var + 2 var²) / Σ R² with b̂² = b² − var."""
    rng = np.random.default_rng(20)
    r, b = _truth(), 0.03
    var = rng.uniform(0.0, 2e-4, r.shape)
    result = seed_relative_mse(r, var, np.stack([r + b] * 5))
    energy = np.sum(r**2)
    raw, floor = r.size * b**2 / energy, var.sum() / energy
    assert result.raw == pytest.approx(raw, rel=1e-12)
    assert result.reference_floor == pytest.approx(floor, rel=1e-12)
    assert result.approx_noise == pytest.approx(0.0, abs=1e-12 * raw)
    assert result.debiased == pytest.approx(raw - floor, rel=1e-9)
    se = np.sqrt(np.sum(4 * (b**2 - var) * var + 2 * var**2)) / energy
    assert result.standard_error == pytest.approx(se, rel=1e-6)
    half = student_t.ppf(0.975, 4) * se
    assert result.interval == pytest.approx((raw - floor - half, raw - floor + half), rel=1e-6)


def test_one_seed_has_no_noise_estimate_and_no_interval():
    rng = np.random.default_rng(21)
    r = _truth()
    var = np.full_like(r, 1e-4)
    frame = r * 1.02 + 0.01 * rng.standard_normal(r.shape)
    result = seed_relative_mse(r, var, frame[None])
    energy = np.sum(r**2)
    assert np.isnan(result.approx_noise) and np.isnan(result.standard_error)
    assert result.interval is None and result.seeds == 1
    assert result.raw == pytest.approx(np.sum((frame - r) ** 2) / energy, rel=1e-12)
    assert result.debiased == pytest.approx(result.raw - var.sum() / energy, rel=1e-12)


@pytest.mark.parametrize("s", [2, 3, 4])
def test_an_interval_needs_min_seeds(s):
    """Two or three seeds estimate the seeds' noise (and subtract it) but give no
    standard error or interval; MIN_SEEDS_FOR_INTERVAL = 4 do."""
    reference, var, frames, _ = _biased_frames(np.random.default_rng(22), s)
    result = seed_relative_mse(reference, var, frames)
    assert MIN_SEEDS_FOR_INTERVAL == 4
    assert np.isfinite(result.approx_noise) and result.seeds == s
    assert result.debiased == pytest.approx(_brute_force(reference, var, frames), rel=1e-10)
    if s < MIN_SEEDS_FOR_INTERVAL:
        assert np.isnan(result.standard_error) and result.interval is None
    else:
        assert result.standard_error > 0
        lo, hi = result.interval
        assert lo < result.debiased < hi


# --- seed_relative_mse: identities -------------------------------------------------


def test_approx_noise_is_the_sample_variance_over_seeds():
    """approx_noise = Σ s² / S / Σ R² with s² numpy's sample variance (ddof 1) over
    the seeds, and debiased = raw − floor − approx_noise = the mean over pairs i ≠ j
    of Σ (A_i − R)(A_j − R) / Σ R², less the floor (the U-statistic)."""
    rng = np.random.default_rng(23)
    r = _truth()
    var = rng.uniform(0.0, 1e-4, r.shape)
    frames = r * 1.03 + 0.05 * rng.standard_normal((6, *r.shape))
    result = seed_relative_mse(r, var, frames)
    energy = np.sum(r**2)
    s = len(frames)
    assert result.approx_noise == pytest.approx(np.sum(frames.var(axis=0, ddof=1)) / s / energy, rel=1e-10)
    assert result.raw == pytest.approx(np.sum((frames.mean(axis=0) - r) ** 2) / energy, rel=1e-12)
    assert result.reference_floor == pytest.approx(var.sum() / energy, rel=1e-12)
    assert result.debiased == pytest.approx(result.raw - result.reference_floor - result.approx_noise, rel=1e-10)
    pairs = [np.sum((frames[i] - r) * (frames[j] - r)) for i in range(s) for j in range(s) if i != j]
    assert result.debiased == pytest.approx(np.mean(pairs) / energy - var.sum() / energy, rel=1e-10)
    assert result.debiased == pytest.approx(_brute_force(r, var, frames), rel=1e-10)


@pytest.mark.parametrize("level", [0.5, 0.9])
def test_standard_error_is_the_explicit_jackknife_plus_the_reference_part(level):
    """The Gram-matrix shortcut against a delete-one jackknife over explicit frame
    stacks (the brute-force estimate without seed i), plus R's part
    Σ(4 b̂² var + 2 var²) / (Σ R²)², b̂² = max(d̄² − s²/S − var, 0); the interval is
    the estimate ± Student-t quantile (S − 1 dof) × SE."""
    rng = np.random.default_rng(24)
    r = _truth()
    var = rng.uniform(0.0, 4e-4, r.shape)
    s = 5
    frames = r * 1.03 + 0.05 * rng.standard_normal((s, *r.shape))
    result = seed_relative_mse(r, var, frames, level=level)
    leave_out = np.array([_brute_force(r, var, np.delete(frames, i, axis=0)) for i in range(s)])
    jackknife = (s - 1) / s * np.sum((leave_out - leave_out.mean()) ** 2)
    d = frames - r
    bias_part = max(np.sum((d.mean(axis=0) ** 2 - d.var(axis=0, ddof=1) / s - var) * var), 0.0)
    reference_part = (4 * bias_part + np.sum(2 * var**2)) / np.sum(r**2) ** 2
    assert reference_part > 0.05 * jackknife  # the reference part matters here
    assert result.standard_error == pytest.approx(np.sqrt(jackknife + reference_part), rel=1e-9)
    half = student_t.ppf(0.5 + level / 2, s - 1) * result.standard_error
    assert result.interval == pytest.approx((result.debiased - half, result.debiased + half), rel=1e-9)
    assert result.level == level


def test_debiased_error_is_the_bias_alone():
    """Frames R(1 + δ) + N(0, σ²) for S = 8 seeds against a reference R + N(0, v_R)
    whose variance v_R is given: the debiased relMSE estimates Σ(R δ)² / Σ R_given².

    Tolerance from the noise: with m = R δ per value and v = σ²/S + v_R the variance
    of the mean's difference, Σ(Ā − R)² has the variance Σ(4 m² v + 2 v²); the seeds'
    Σ s²/S (independent of the mean for Gaussian noise) adds Σ 2 σ⁴ / (S² (S − 1)).
    Five of those standard deviations, over Σ R²."""
    s, sigma, ref_sd = 8, 0.05, 0.01
    reference, var, frames, m = _biased_frames(np.random.default_rng(22), s, sigma, ref_sd)
    result = seed_relative_mse(reference, var, frames)

    energy = np.sum(reference**2)
    v = sigma**2 / s + ref_sd**2
    sd = np.sqrt(np.sum(4 * m**2 * v + 2 * v**2) + m.size * 2 * sigma**4 / (s**2 * (s - 1))) / energy
    assert result.debiased == pytest.approx(np.sum(m**2) / energy, abs=5 * sd)
    # the noise is a large part of the raw error: without debiasing the test above would fail
    assert result.raw - np.sum(m**2) / energy > 20 * sd
    # the noise terms are what they should be (the seeds' within 5 SDs of a variance from 7 dof, per value)
    assert result.reference_floor == pytest.approx(var.sum() / energy, rel=1e-12)
    assert result.approx_noise == pytest.approx(m.size * sigma**2 / s / energy, rel=5 * np.sqrt(2 / (7 * m.size)))
    # and the stated SE is of the size of that noise (the formula above is its expectation)
    assert result.standard_error == pytest.approx(sd, rel=0.5)


# --- seed_relative_mse: calibration over simulated draws ----------------------------

DRAWS = 200
CALIBRATION = {  # case: (relative bias δ, σ of a frame, σ of the reference)
    # σ²/S per value is 3-6e-4 against a bias² ≤ 1e-5: the estimate is mostly noise
    "noise": (lambda: np.full((H, W, 1), 0.003), 0.05, 0.005),
    # bias² ≈ 1e-3 per value; R's noise (redrawn each draw) gives ~half the variance
    "bias": (_delta, 0.05, 0.02),
}


@pytest.mark.parametrize("s", [4, 8])
@pytest.mark.parametrize("case", list(CALIBRATION))
def test_interval_covers_the_bias_and_the_standard_error_matches_the_spread(case, s):
    """Over 200 independent draws (new frames and a new reference noise each time),
    the 95% interval holds the true Σ(R δ)² / Σ R² in 93–100% of them, and the stated
    standard error is at least 0.9× the spread of the estimates and at most what the
    jackknife's known upward bias allows.

    The delete-one jackknife of this degenerate U-statistic has the expectation
    4Var(h₁)/S + 4Σv²/(S(S−2)) against the true 4Var(h₁)/S + 2Σv²/(S(S−1)) (v the
    per-pixel variance of one frame): at most 2(S−1)/(S−2) times too large where
    the approximation's noise dominates — 3 at S = 4, 2.33 at S = 8 — an SE ratio up
    to 1.73 and 1.53, plus sampling error (≈ 10%): the bounds 1.95 and 1.7. Where the
    bias dominates the ratio tends to 1 (0.9–1.3). The interval is therefore
    conservative (coverage up to 100%), never too narrow.

    Coverage: the number of covering draws is binomial; at 95% its sd over 200 draws
    is √(0.95·0.05/200) ≈ 1.5%, so 93% is 1.3 of them below nominal — the lower bound
    catches an interval that is too narrow (false alarms) with room for the Student-t
    approximation (about S − 1 degrees of freedom).

    SE: compared as the RMS of the 200 SEs (the jackknife estimates a variance; the
    mean of SEs from ~3 dof would sit ~8% below by Jensen) against the sample sd of
    the 200 estimates (relative sampling error 1/√398 ≈ 5%; the RMS's from 200
    variances of ≥ 3 dof ≤ 3%). The estimates' mean must also be
    the truth within 4 of its standard errors (the estimator is unbiased)."""
    shape_delta, sigma, ref_sd = CALIBRATION[case]
    rng = np.random.default_rng(300 + 10 * s + len(case))
    truth = _truth()
    m = truth * shape_delta()
    target = np.sum(m**2) / np.sum(truth**2)
    var = np.full_like(truth, ref_sd**2)
    estimates, errors, covered = [], [], 0
    for _ in range(DRAWS):
        reference = truth + ref_sd * rng.standard_normal(truth.shape)
        frames = truth + m + sigma * rng.standard_normal((s, *truth.shape))
        result = seed_relative_mse(reference, var, frames)
        estimates.append(result.debiased)
        errors.append(result.standard_error)
        lo, hi = result.interval
        covered += lo <= target <= hi
    spread = np.std(estimates, ddof=1)
    se_ratio = np.sqrt(np.mean(np.square(errors))) / spread
    summary = (f"{case}, S = {s}: coverage {covered}/{DRAWS}, RMS SE / spread = {se_ratio:.2f} "
               f"(mean SE / spread = {np.mean(errors) / spread:.2f})")
    assert np.mean(estimates) == pytest.approx(target, abs=4 * spread / np.sqrt(DRAWS)), summary
    assert covered >= 0.93 * DRAWS, summary
    upper = {("noise", 4): 1.95, ("noise", 8): 1.7}.get((case, s), 1.3)
    assert 0.9 <= se_ratio <= upper, summary


# --- seed_relative_mse: the compared pixels and bad input -----------------------------


def test_mask_selects_the_pixels():
    rng = np.random.default_rng(25)
    r = _truth()
    var = np.full_like(r, 1e-4)
    frames = r * 1.02 + 0.02 * rng.standard_normal((4, *r.shape))
    mask = np.ones((H, W), bool)
    mask[:, :6] = False
    garbage = frames.copy()
    garbage[:, :, :6] += 10.0
    masked = seed_relative_mse(r, var, garbage, mask=mask)
    assert masked == seed_relative_mse(r, var, frames, mask=mask)
    assert masked.pixels == int(mask.sum())
    assert masked.debiased == pytest.approx(_brute_force(r[mask], var[mask], frames[:, mask]), rel=1e-10)
    assert masked != seed_relative_mse(r, var, garbage)


@pytest.mark.parametrize("bad", ["frame_shape", "var_shape", "no_frame", "zero_reference", "level_one",
                                 "level_zero", "negative_var", "not_finite"])
def test_seed_relative_mse_bad_input(bad):
    r = _truth()
    var, frames, kwargs = np.zeros_like(r), np.stack([r * 1.01] * 4), {}
    if bad == "frame_shape":
        frames = frames[:, :-1]
    elif bad == "var_shape":
        var = var[..., :2]
    elif bad == "no_frame":
        frames = frames[:0]
    elif bad == "zero_reference":
        r = np.zeros_like(r)
    elif bad == "level_one":
        kwargs["level"] = 1.0
    elif bad == "level_zero":
        kwargs["level"] = 0.0
    elif bad == "negative_var":  # as metrics.noise.noise_floor rejects it
        var = np.full_like(r, -1e-4)
    else:
        frames[1, 3, 4, 0] = np.nan
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
    weights = bootstrap_weights(6, 500, 4)
    means = [np.repeat(values, w.astype(int)).mean() for w in weights]
    assert (lo, hi) == pytest.approx(tuple(np.percentile(means, [2.5, 97.5])), rel=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_seed_mean_interval_needs_min_seeds(n):
    values = [0.25, 0.31, 0.22, 0.28][:n]
    result = seed_mean_interval(values)
    assert result["mean"] == pytest.approx(np.mean(values), rel=1e-12) and result["seeds"] == n
    if n < MIN_SEEDS_FOR_INTERVAL:
        assert result["interval"] is None and result["resamples"] == 0
    else:
        assert result["interval"] is not None and result["resamples"] == 2000


def test_bootstrap_weights_are_deterministic_multiplicities():
    a, b = bootstrap_weights(6, 50, 7), bootstrap_weights(6, 50, 7)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, bootstrap_weights(6, 50, 8))
    assert np.all(a >= 0) and np.all(a == np.round(a)) and np.all(a.sum(axis=1) == 6)


@pytest.mark.parametrize("values", [[0.1, np.nan, 0.2], [0.1, np.inf], []])
def test_seed_mean_interval_rejects_missing_values(values):
    with pytest.raises(ValueError):
        seed_mean_interval(values)


@pytest.mark.parametrize("level", [0.0, 1.0, 1.5, -0.1])
def test_seed_mean_interval_rejects_a_bad_level(level):
    with pytest.raises(ValueError):
        seed_mean_interval([0.1, 0.2, 0.3, 0.4], level=level)


# --- noisy_copy ----------------------------------------------------------------------


def test_noisy_copy_is_deterministic_and_nonnegative():
    rng = np.random.default_rng(26)
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
