"""The one-frame error (metrics.frame) on synthetic frames with a known bias and noise:
unbiased for (Σ b² + Σ var_A)/Σ R², its standard error calibrated over repeats, and
noisier frames with the same mean score worse while the debiased mean error does not
move (the negative control: the mean's bias cannot see a frame's noise)."""

from __future__ import annotations

import numpy as np

from volcaustics.metrics.frame import frame_relative_mse
from volcaustics.metrics.noise import seed_relative_mse

H, W, S = 24, 24, 8


def _case(rng, noise: float, ref_sigma: float = 0.05):
    truth = 1.0 + 0.5 * np.sin(np.linspace(0, 3, H * W)).reshape(H, W, 1).repeat(3, axis=2)
    bias = 0.1 * truth
    reference = truth + ref_sigma * rng.standard_normal(truth.shape)
    frames = truth + bias + noise * rng.standard_normal((S, *truth.shape))
    expected = (np.sum(bias**2) + noise**2 * truth.size) / np.sum(truth**2)
    return reference, np.full(truth.shape, ref_sigma**2), frames, expected


def test_one_frame_error_is_unbiased_and_its_standard_error_calibrated():
    """Over 300 repeats: the mean estimate within 4 SE of the truth, and the spread of
    the estimates within 0.8–1.25 of the mean reported SE (the calibration's band: the
    SE of a standard deviation over 300 repeats is 4%, with a little room)."""
    rng = np.random.default_rng(3)
    values, ses, expected = [], [], None
    for _ in range(300):
        reference, var, frames, expected = _case(rng, noise=0.2)
        err = frame_relative_mse(reference, var, frames)
        values.append(err.debiased)
        ses.append(err.standard_error)
    values = np.asarray(values)
    assert abs(values.mean() - expected) <= 4 * values.std(ddof=1) / np.sqrt(len(values)), (values.mean(), expected)
    assert 0.8 <= values.std(ddof=1) / np.mean(ses) <= 1.25, values.std(ddof=1) / np.mean(ses)


def test_noisier_frames_score_worse_one_frame_but_not_in_the_mean():
    rng = np.random.default_rng(5)
    calm_ref, var, calm, _ = _case(rng, noise=0.05)
    noisy = calm + 0.3 * rng.standard_normal(calm.shape)
    one_calm, one_noisy = (frame_relative_mse(calm_ref, var, f) for f in (calm, noisy))
    assert one_noisy.debiased > one_calm.debiased + 5 * (one_calm.standard_error + one_noisy.standard_error)
    mean_calm, mean_noisy = (seed_relative_mse(calm_ref, var, f) for f in (calm, noisy))
    assert abs(mean_noisy.debiased - mean_calm.debiased) < 4 * np.hypot(mean_calm.standard_error,
                                                                          mean_noisy.standard_error)
