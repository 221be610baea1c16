"""Statistical comparison of Monte Carlo estimates with per-pixel variance.

The z-test follows Mitsuba 3's own render regression tests: per pixel
z = (a − b) / sqrt(var_a + var_b), two-sided p-values, and a Šidák-corrected
significance level α' = 1 − (1 − α)^(1/n) over the n tested pixels so that the
family of tests has level α. A comparison passes when at least ``min_pass_rate``
of the pixels are not rejected; ``var_floor`` guards pixels whose estimated
variance is (nearly) zero, as Mitsuba's tests floor theirs.

Variances estimated from few batches are themselves noisy: with B batches z
follows Student's t with B − 1 degrees of freedom, not a normal distribution
(4 batches: |z| > 3.2 happens 5% of the time instead of 0.1%). Given the batch
counts, the p-values come from t with the Welch–Satterthwaite degrees of freedom
(:func:`welch_dof`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


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


def welch_dof(var_a: ArrayLike, batches_a: int, var_b: ArrayLike, batches_b: int) -> np.ndarray:
    """Welch–Satterthwaite degrees of freedom of var_a + var_b, each the variance of a
    mean over that many batches (per pixel; ∞ where both are 0)."""
    va, vb = np.asarray(var_a, np.float64), np.asarray(var_b, np.float64)
    num = (va + vb) ** 2
    den = va * va / max(batches_a - 1, 1) + vb * vb / max(batches_b - 1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, np.inf)


def p_values(z: ArrayLike, dof: ArrayLike | None = None) -> np.ndarray:
    """Two-sided p-values of |z|: normal, or Student's t with ``dof`` (scalar or per value)."""
    from scipy.special import erfc
    from scipy.stats import t as student_t

    z = np.abs(np.asarray(z, np.float64))
    if dof is None:
        return erfc(z / np.sqrt(2.0))
    dof = np.broadcast_to(np.asarray(dof, np.float64), z.shape)
    finite = np.isfinite(dof)
    out = erfc(z / np.sqrt(2.0))
    out[finite] = 2.0 * student_t.sf(z[finite], dof[finite])
    return out


def z_test(reference_mean: ArrayLike, reference_var: ArrayLike, test_mean: ArrayLike, test_var: ArrayLike, *,
           alpha: float = 0.01, min_pass_rate: float = 0.99, var_floor: float = 0.0,
           batches: tuple | None = None) -> ZTestResult:
    """Per-pixel z-test of two independent unbiased estimates of the same image.

    Parameters
    ----------
    reference_mean, test_mean : H×W×C arrays, linear radiance, any sign.
    reference_var, test_var : H×W×C arrays ≥ 0, variance of each mean.
    alpha : family-wise significance level.
    min_pass_rate : fraction of pixels that must pass.
    var_floor : added to the summed variance (guards pixels where both estimates
        are exactly equal with zero variance; those are skipped when 0).
    batches : (reference batches, test batches) the variances were estimated from;
        then p-values come from Student's t (:func:`welch_dof`), else the normal.
    """
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
    dof = welch_dof(arrays[1], batches[0], arrays[3], batches[1])[tested] if batches else None
    p = p_values(z, dof)
    a_sidak = sidak_alpha(alpha, n)
    rate = float(np.mean(p >= a_sidak))
    return ZTestResult(rate >= min_pass_rate, rate, alpha, a_sidak, n, float(p.min()), float(z.max()), min_pass_rate)
