"""Statistical comparison of Monte Carlo estimates with per-pixel variance.

The z-test follows Mitsuba 3's own render regression tests: per pixel
z = (a − b) / sqrt(var_a + var_b), two-sided p-values, and a Šidák-corrected
significance level α' = 1 − (1 − α)^(1/n) over the n tested pixels so that the
family of tests has level α. A comparison passes when at least ``min_pass_rate``
of the pixels are not rejected.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ZTestResult:
    passed: bool
    pass_rate: float  # fraction of tested pixels with p >= alpha_sidak
    alpha: float
    alpha_sidak: float
    tested: int  # pixels with non-zero variance
    min_p: float
    max_abs_z: float
    min_pass_rate: float


def sidak_alpha(alpha: float, n: int) -> float:
    """Per-test level so that n independent tests have family-wise level alpha."""
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must lie in (0, 1), got {alpha}")
    return float(-np.expm1(np.log1p(-alpha) / max(n, 1)))


def z_test(reference_mean, reference_var, test_mean, test_var, *, alpha: float = 0.01,
           min_pass_rate: float = 0.99, var_floor: float = 0.0) -> ZTestResult:
    """Per-pixel z-test of two independent unbiased estimates of the same image.

    Parameters
    ----------
    reference_mean, test_mean : H×W×C arrays, linear radiance, any sign.
    reference_var, test_var : H×W×C arrays ≥ 0, variance of each mean.
    alpha : family-wise significance level.
    min_pass_rate : fraction of pixels that must pass.
    var_floor : added to the summed variance (guards pixels where both estimates
        are exactly equal with zero variance; those are skipped when 0).
    """
    from scipy.special import erfc

    arrays = [np.asarray(x, dtype=np.float64) for x in (reference_mean, reference_var, test_mean, test_var)]
    shape = arrays[0].shape
    if any(a.shape != shape for a in arrays):
        raise ValueError(f"shape mismatch: {[a.shape for a in arrays]}")
    if np.any(arrays[1] < 0) or np.any(arrays[3] < 0):
        raise ValueError("variances must be non-negative")
    var = arrays[1] + arrays[3] + var_floor
    tested = var > 0
    n = int(tested.sum())
    if n == 0:
        raise ValueError("no pixel has a non-zero variance: nothing to test")
    z = np.abs(arrays[0] - arrays[2])[tested] / np.sqrt(var[tested])
    p = erfc(z / np.sqrt(2.0))
    a_sidak = sidak_alpha(alpha, n)
    rate = float(np.mean(p >= a_sidak))
    return ZTestResult(rate >= min_pass_rate, rate, alpha, a_sidak, n, float(p.min()), float(z.max()), min_pass_rate)
