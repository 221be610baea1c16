"""The z-test: calibrated on synthetic estimates with known mean and variance."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.metrics.stats import sidak_alpha, z_test


def _estimates(rng, truth, sigma, n_batches):
    batches = truth + rng.normal(0, sigma, size=(n_batches, *truth.shape))
    return batches.mean(0), batches.var(0, ddof=1) / n_batches


def test_sidak_alpha():
    assert sidak_alpha(0.01, 1) == pytest.approx(0.01)
    a = sidak_alpha(0.01, 1000)
    assert (1 - a) ** 1000 == pytest.approx(0.99)


def test_same_truth_passes_and_bias_fails():
    rng = np.random.default_rng(3)
    truth = rng.uniform(1, 2, size=(32, 32, 3))
    a_mean, a_var = _estimates(rng, truth, 0.05, 64)
    b_mean, b_var = _estimates(rng, truth, 0.05, 64)
    assert z_test(a_mean, a_var, b_mean, b_var).passed
    c_mean, c_var = _estimates(rng, truth * 1.1, 0.05, 64)  # 10% bias, noise 0.6%: must fail
    result = z_test(a_mean, a_var, c_mean, c_var)
    assert not result.passed and result.pass_rate < 0.5


def test_identity_and_input_checks():
    x = np.ones((4, 4, 3))
    with pytest.raises(ValueError):
        z_test(x, np.zeros_like(x), x, np.zeros_like(x))  # nothing to test
    with pytest.raises(ValueError):
        z_test(x, x, x[:2], x[:2])
    with pytest.raises(ValueError):
        z_test(x, -x, x, x)
    r = z_test(x, x, x, x)
    assert r.passed and r.max_abs_z == 0.0


def test_relative_mse_identities():
    from volcaustics.metrics.image import relative_mse

    rng = np.random.default_rng(0)
    x = rng.random((8, 8, 3))
    assert relative_mse(x, x) == 0.0
    assert relative_mse(x, 1.1 * x) == pytest.approx(0.01)  # (0.1 x)² / x²
    mask = np.zeros((8, 8), bool)
    mask[:4] = True
    y = x.copy()
    y[4:] += 5
    assert relative_mse(x, y, mask=mask) == 0.0
    with pytest.raises(ValueError):
        relative_mse(x, x[:4])
    with pytest.raises(ValueError):
        relative_mse(np.zeros_like(x), x)


def test_few_batches_need_students_t():
    """Equal images estimated from 4 batches each: with the normal distribution far more
    than 5% of the pixels get p < 0.05 (the variance estimate itself is noisy); with
    Student's t and the Welch–Satterthwaite degrees of freedom they are near uniform.
    Tolerances: 200,000 pixels, so a rate's standard deviation is 0.05 % points."""
    from volcaustics.metrics.stats import p_values, welch_dof

    rng = np.random.default_rng(3)
    a = rng.normal(size=(4, 200_000))
    b = rng.normal(size=(4, 200_000))
    va, vb = a.var(0, ddof=1) / 4, b.var(0, ddof=1) / 4
    z = (a.mean(0) - b.mean(0)) / np.sqrt(va + vb)
    normal = np.mean(p_values(z) < 0.05)
    student = np.mean(p_values(z, welch_dof(va, 4, vb, 4)) < 0.05)
    assert normal > 0.08  # measured 0.10
    assert 0.035 < student <= 0.05  # Welch's approximation is a little conservative at 3 + 3 dof: measured 0.041
    # and z_test with batches passes equal data the normal version rejects more often
    r_normal = z_test(a.mean(0), va, b.mean(0), vb, alpha=0.05, min_pass_rate=0.0)
    r_student = z_test(a.mean(0), va, b.mean(0), vb, alpha=0.05, min_pass_rate=0.0, batches=(4, 4))
    assert r_student.pass_rate > r_normal.pass_rate
