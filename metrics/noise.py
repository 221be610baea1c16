"""Noise-aware comparison of two Monte Carlo images (pure numpy, float64 accumulation).

docs/concepts/measuring.md: a reference stores the variance of its mean per pixel; its
noise floor Σ var / Σ mean² is the relative MSE an exact renderer would get
against it. Comparing two unbiased estimates of one image, their squared
difference has the expectation Σ bias² + Σ (var_test + var_reference): the
*debiased* relative MSE subtracts the second term, so it estimates the error that
noise does not explain, and comes with its standard error so that "within noise"
is a number. Both images are given as independent batch images (K for the test, L
for the reference), which yield the per-pixel variances, the variances of the
totals (pixels that share a sample are correlated, e.g. one splat over several
pixels) and a distribution-free standard error (photon noise is heavy-tailed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def masked_pixels(image: np.ndarray, mask: ArrayLike | None) -> np.ndarray:
    """Pixels of ``image`` (H×W×C or H×W) under ``mask`` (H×W or H×W×C) as N×C."""
    m = np.ones(image.shape[:2], bool) if mask is None else np.asarray(mask, dtype=bool)
    if m.ndim < 2 or m.shape != image.shape[: m.ndim]:
        raise ValueError(f"mask shape {m.shape} does not match image shape {image.shape}")
    selected = image[m]
    return selected.reshape(len(selected), -1)


def _batches(reference_batches, test_batches, mask):
    """Both batch stacks as L×N×C and K×N×C float64 arrays of the masked pixels."""
    r = np.asarray(reference_batches, dtype=np.float64)
    t = np.asarray(test_batches, dtype=np.float64)
    if r.ndim < 3 or t.ndim != r.ndim or r.shape[1:] != t.shape[1:]:
        raise ValueError(f"shape mismatch: reference_batches {r.shape}, test_batches {t.shape} "
                         "(expected L×H×W×C and K×H×W×C)")
    for name, b in (("reference_batches", r), ("test_batches", t)):
        if len(b) < 4:
            raise ValueError(f"{name}: {len(b)} batches, expected at least 4")
    r = np.stack([masked_pixels(b, mask) for b in r])
    t = np.stack([masked_pixels(b, mask) for b in t])
    return r, t


def _variance_squared(batches):
    """Unbiased per-pixel estimate of var(mean)² from one batch stack (n×N×C): the
    product of the variances of two disjoint halves is unbiased for σ⁴ whatever the
    distribution (a ``firefly`` in one batch gives ≈ 0, as it should), averaged over
    two splits (first/second half, even/odd)."""
    n = len(batches)
    h = n // 2
    splits = [(batches[:h], batches[h:2 * h]), (batches[0:2 * h:2], batches[1:2 * h:2])]
    sigma4 = np.mean([a.var(axis=0, ddof=1) * b.var(axis=0, ddof=1) for a, b in splits], axis=0)
    return sigma4 / n**2


def noise_floor(reference: ArrayLike, reference_var: ArrayLike, *, mask: ArrayLike | None = None) -> float:
    """Σ var / Σ mean² over the pixels of ``mask``: the reference's own noise as a
    relative MSE (docs/concepts/measuring.md.

    Parameters
    ----------
    reference : H×W×C array, linear radiance, the mean of the batches.
    reference_var : H×W×C array ≥ 0, the variance of that mean per pixel.
    mask : optional H×W (or H×W×C) boolean array of the pixels to count.
    """
    r = np.asarray(reference, dtype=np.float64)
    rv = np.asarray(reference_var, dtype=np.float64)
    if r.shape != rv.shape or r.ndim < 2:
        raise ValueError(f"shape mismatch: reference {r.shape}, reference_var {rv.shape}")
    if np.any(rv < 0):
        raise ValueError("reference_var must be non-negative")
    r, rv = masked_pixels(r, mask), masked_pixels(rv, mask)
    energy = float(np.sum(r * r))
    if energy == 0.0:
        raise ValueError("reference is zero everywhere: relative error undefined")
    return float(np.sum(rv) / energy)


def total_sigma(image_var: ArrayLike, *, mask: ArrayLike | None = None, ratio: ArrayLike | None = None) -> np.ndarray:
    """Per channel, the standard deviation of an image's total over ``mask`` from its
    per-pixel variances ``image_var`` (…×C; ``mask`` None: every pixel): √(ratio_c · Σ var_c), ``ratio`` the image's
    measured variance of the total over Σ var (``reference.render.batches.
    total_variance_ratio``, over the pixels free of glass; None: 1, pixels independent)."""
    v = np.asarray(image_var, dtype=np.float64)
    v = (v.reshape(-1, v.shape[-1]) if mask is None else masked_pixels(v, mask)).sum(axis=0)
    return np.sqrt(v * (1.0 if ratio is None else np.asarray(ratio, np.float64)))


@dataclass(frozen=True)
class EnergyRatio:
    """Per-channel ratio of the test's total to the reference's over the masked pixels."""

    ratio: np.ndarray                # C, test total / reference total
    standard_error: np.ndarray       # C, of the ratio (first-order propagation of both variances)
    test_total: np.ndarray           # C, Σ test over the pixels
    test_total_var: np.ndarray       # C, variance of that sum, from the batches' totals
    reference_total: np.ndarray      # C
    reference_total_var: np.ndarray  # C
    pixels: int
    batches: int
    reference_batches: int


def batch_energy_ratio(reference_batches: ArrayLike, test_batches: ArrayLike, *,
                       mask: ArrayLike | None = None) -> EnergyRatio:
    """Energy of a test image relative to a reference, both as independent batches.

    Parameters
    ----------
    reference_batches : L×H×W×C array, L ≥ 4 independent unbiased estimates of the
        reference image (linear radiance); the reference is their mean.
    test_batches : K×H×W×C array, K ≥ 4 independent estimates of the test image.
    mask : optional H×W (or H×W×C) boolean array of the pixels to sum.

    The variance of each total comes from the spread of the batches' totals, so
    pixels that share a sample (one splat over several pixels) are accounted for.
    """
    r, t = _batches(reference_batches, test_batches, mask)
    ref_totals, test_totals = r.sum(axis=1), t.sum(axis=1)  # batches × C
    ref_total, test_total = ref_totals.mean(axis=0), test_totals.mean(axis=0)
    ref_var = ref_totals.var(axis=0, ddof=1) / len(r)
    test_var = test_totals.var(axis=0, ddof=1) / len(t)
    if np.any(ref_total <= 0):
        raise ValueError("reference total is not positive in every channel: ratio undefined")
    ratio = test_total / ref_total
    rel_var = test_var / np.maximum(np.abs(test_total), 1e-300) ** 2 + ref_var / ref_total**2
    return EnergyRatio(ratio=ratio, standard_error=np.abs(ratio) * np.sqrt(rel_var), test_total=test_total,
                       test_total_var=test_var, reference_total=ref_total, reference_total_var=ref_var,
                       pixels=int(r.shape[1]), batches=len(t), reference_batches=len(r))


@dataclass(frozen=True)
class DebiasedRelMSE:
    """Relative MSE of a test image against a reference, split into noise and the rest.

    raw = Σ(test − reference)² / Σ reference² (means of the batches); noise =
    Σ(var_test + var_reference) / Σ reference², the expectation of raw when both are
    unbiased estimates of one image (variances of the means, from the batches);
    debiased = raw − noise, an unbiased estimate of Σ bias² / Σ reference² (negative
    values are noise); standard_error of ``debiased``; z = debiased / standard_error.
    """

    raw: float
    noise: float
    test_noise: float
    reference_noise: float
    debiased: float
    standard_error: float
    z: float
    pixels: int
    batches: int
    reference_batches: int


def debiased_relative_mse(reference_batches: ArrayLike, test_batches: ArrayLike, *,
                          mask: ArrayLike | None = None) -> DebiasedRelMSE:
    """Relative MSE of a batched test image against a batched reference, less what
    their noise explains, with a standard error.

    Parameters
    ----------
    reference_batches : L×H×W×C array, L ≥ 4 independent unbiased estimates of the
        reference image (linear radiance).
    test_batches : K×H×W×C array, K ≥ 4 independent estimates of the test image.
    mask : optional H×W (or H×W×C) boolean array of the pixels to compare.

    Notes
    -----
    Per pixel, with b the bias, d = mean_test − mean_reference and v_t, v_r the
    variances of the two means, T = d² − v̂_t − v̂_r is unbiased for b² and, for any
    distribution of the batches, has the variance
    4 b² (v_t + v_r) + 2 v_t² K/(K−1) + 2 v_r² L/(L−1) + 4 v_t v_r
    (the terms are uncorrelated: T is a U-statistic). Pixels are taken as
    independent; v² comes from products of disjoint half-sample variances (unbiased,
    robust to fireflies), b² (v_t + v_r) from T·(v̂_t + v̂_r) summed.
    """
    r, t = _batches(reference_batches, test_batches, mask)
    k, n_ref = len(t), len(r)
    ref_mean, test_mean = r.mean(axis=0), t.mean(axis=0)
    energy = float(np.sum(ref_mean**2))
    if energy == 0.0:
        raise ValueError("reference is zero everywhere: relative error undefined")
    v_t = t.var(axis=0, ddof=1) / k
    v_r = r.var(axis=0, ddof=1) / n_ref
    d2 = (test_mean - ref_mean) ** 2
    per_pixel = d2 - v_t - v_r
    variance = (2 * _variance_squared(t) * k / (k - 1) + 2 * _variance_squared(r) * n_ref / (n_ref - 1)
                + 4 * v_t * v_r)
    bias_part = max(float(np.sum(4 * per_pixel * (v_t + v_r))), 0.0)
    se = float(np.sqrt(max(float(np.sum(variance)), 0.0) + bias_part))
    debiased = float(np.sum(per_pixel))
    z = debiased / se if se > 0 else (0.0 if debiased == 0 else float(np.copysign(np.inf, debiased)))
    return DebiasedRelMSE(raw=float(np.sum(d2)) / energy, noise=float(np.sum(v_t) + np.sum(v_r)) / energy,
                         test_noise=float(np.sum(v_t)) / energy, reference_noise=float(np.sum(v_r)) / energy,
                         debiased=debiased / energy, standard_error=se / energy, z=z,
                         pixels=int(r.shape[1]), batches=k, reference_batches=n_ref)


# --- errors of the approximation over its seeds ------------------------------------
#
# The approximation is biased; its own noise comes from its seeds (free flights,
# Fresnel choices). Given S frames with different seeds and a reference with a
# per-pixel variance, the *debiased* relative MSE estimates Σ bias² / Σ R² (docs/concepts/measuring.md),
# with an interval over the seeds.

MIN_SEEDS_FOR_INTERVAL = 4  # fewer seeds: no interval (a bootstrap of 2 values is their range)


@dataclass(frozen=True)
class SeedsRelMSE:
    """Relative MSE of the mean of S approximation frames against a reference.

    raw = Σ(Ā − R)² / Σ R²; reference_floor = Σ var_R / Σ R²; approx_noise = the
    variance of Ā over seeds, Σ s²/S / Σ R² (nan with one seed: not estimated, and
    not subtracted); debiased = raw − reference_floor − approx_noise; standard_error
    of ``debiased`` (nan below MIN_SEEDS_FOR_INTERVAL seeds) and the Student-t
    ``interval`` at ``level`` (None then).
    """

    raw: float
    reference_floor: float
    approx_noise: float
    debiased: float
    standard_error: float
    interval: tuple | None
    seeds: int
    level: float
    pixels: int


def seed_relative_mse(reference: ArrayLike, reference_var: ArrayLike, seed_images: ArrayLike, *,
                      mask: ArrayLike | None = None, level: float = 0.95) -> SeedsRelMSE:
    """Debiased relative MSE of S approximation frames (S×H×W×C) against a reference
    (mean H×W×C and the variance of that mean per pixel), with its standard error.

    With D_s = A_s − R and G their Gram matrix over the pixels, raw − approx_noise is
    the mean of the off-diagonal entries G_ij (i ≠ j): a U-statistic over the seeds,
    unbiased for Σ bias² + Σ var_R. Its standard error is a delete-one jackknife over
    the seeds (cheap from G; a plain bootstrap of a degenerate U-statistic is
    miscalibrated when the bias is small), plus what R's own noise adds — R is the
    same in every seed — 4 Σ b̂² var_R + 2 Σ var_R² (b̂² = d² − var per pixel, the
    sum clipped at 0). The jackknife overstates the noise×noise part of the variance
    (Efron–Stein: 4Σv²/(S(S−2)) against 2Σv²/(S(S−1))), so the interval is conservative
    where the approximation's noise dominates its bias (docs/decisions.md "Jackknife
    calibration").
    """
    r = np.asarray(reference, np.float64)
    rv = np.asarray(reference_var, np.float64)
    a = np.asarray(seed_images, np.float64)
    if a.ndim != r.ndim + 1 or a.shape[1:] != r.shape or rv.shape != r.shape:
        raise ValueError(f"shapes: reference {r.shape}, reference_var {rv.shape}, seed_images {a.shape} "
                         "(expected H×W×C, H×W×C, S×H×W×C)")
    if len(a) < 1:
        raise ValueError("seed_images: no frame")
    if not 0 < level < 1:
        raise ValueError(f"level = {level!r}: expected a probability in (0, 1)")
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(a)) and np.all(np.isfinite(rv))) or np.any(rv < 0):
        raise ValueError("reference, reference_var and seed_images must be finite, reference_var ≥ 0")
    sel_r, sel_rv = masked_pixels(r, mask), masked_pixels(rv, mask)
    d = np.stack([masked_pixels(x, mask) for x in a]) - sel_r  # S×N×C
    energy = float(np.sum(sel_r * sel_r))
    if energy == 0.0:
        raise ValueError("reference is zero everywhere: relative error undefined")
    n = len(a)
    flat = d.reshape(n, -1)
    gram = flat @ flat.T
    floor = float(sel_rv.sum()) / energy
    raw = float(gram.sum()) / n**2 / energy
    if n < 2:
        return SeedsRelMSE(raw=raw, reference_floor=floor, approx_noise=float("nan"), debiased=raw - floor,
                         standard_error=float("nan"), interval=None, seeds=n, level=level,
                         pixels=int(sel_r.shape[0]))
    off = float(gram.sum() - np.trace(gram))
    debiased = off / (n * (n - 1)) / energy - floor
    se, interval = float("nan"), None
    if n >= MIN_SEEDS_FOR_INTERVAL:
        from scipy.special import stdtrit  # Student t's quantile (scipy.stats.t.ppf's own), without scipy.stats

        rows = gram.sum(axis=1) - np.diag(gram)  # Σ_{j≠i} G_ij
        leave_out = (off - 2.0 * rows) / ((n - 1) * (n - 2)) / energy
        jackknife = (n - 1) / n * float(np.sum((leave_out - leave_out.mean()) ** 2))
        mean_d = d.mean(axis=0).reshape(-1)
        spread = flat.var(axis=0, ddof=1) / n
        v_r = sel_rv.reshape(-1)
        bias_part = max(float(np.sum((mean_d ** 2 - spread - v_r) * v_r)), 0.0)  # Σ b² var_R, clipped as a sum
        reference_part = (4.0 * bias_part + 2.0 * float(np.sum(v_r ** 2))) / energy**2
        se = float(np.sqrt(jackknife + reference_part))
        half = float(stdtrit(n - 1, 0.5 + level / 2.0)) * se
        interval = (debiased - half, debiased + half)
    return SeedsRelMSE(raw=raw, reference_floor=floor, approx_noise=raw - floor - debiased, debiased=debiased,
                     standard_error=se, interval=interval, seeds=n, level=level, pixels=int(sel_r.shape[0]))


def bootstrap_weights(seeds: int, resamples: int, seed: int) -> np.ndarray:
    """resamples × seeds multiplicities of a bootstrap over the seeds (deterministic)."""
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, seeds, size=(resamples, seeds))
    # each row's bincount, all rows at once (the same draws)
    return (idx[:, :, None] == np.arange(seeds)).sum(axis=1).astype(np.float64)


def seed_mean_interval(values: ArrayLike, *, resamples: int = 2000, level: float = 0.95, seed: int = 0) -> dict:
    """Mean of a per-frame metric over S seeds and its percentile bootstrap interval
    (None below MIN_SEEDS_FOR_INTERVAL seeds)."""
    v = np.asarray(values, np.float64).reshape(-1)
    if len(v) == 0 or not np.all(np.isfinite(v)):
        raise ValueError(f"values: expected finite per-seed values, got {v.tolist()}")
    if not 0 < level < 1:
        raise ValueError(f"level = {level!r}: expected a probability in (0, 1)")
    interval = None
    if len(v) >= MIN_SEEDS_FOR_INTERVAL:
        means = bootstrap_weights(len(v), resamples, seed) @ v / len(v)
        lo, hi = np.percentile(means, [50 * (1 - level), 50 * (1 + level)])
        interval = (float(lo), float(hi))
    return {"mean": float(v.mean()), "interval": interval, "seeds": len(v),
            "resamples": resamples if interval else 0, "level": level}


def noisy_copy(reference: ArrayLike, reference_var: ArrayLike, *, seed: int = 0) -> np.ndarray:
    """The reference plus Gaussian noise of its own per-pixel variance, clipped at 0:
    an image as far from the reference as an exact renderer with the reference's noise
    would be. Metrics that are not quadratic (SSIM, FLIP, ΔE) cannot subtract a floor
    analytically; their floor is the metric of the reference against this copy."""
    r = np.asarray(reference, np.float64)
    rv = np.asarray(reference_var, np.float64)
    if r.shape != rv.shape or np.any(rv < 0):
        raise ValueError(f"reference {r.shape} and reference_var {rv.shape}: expected one shape, variances ≥ 0")
    z = np.random.default_rng(seed).standard_normal(r.shape)
    return np.maximum(r + np.sqrt(rv) * z, 0.0).astype(np.float32)
