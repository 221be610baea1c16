"""Flicker and energy jitter (metrics.temporal) on synthetic sequences with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.metrics.temporal import energy_jitter, flicker

T, H, W = 6, 24, 24


def _truth(rng):
    """A sequence whose true frames change: a bright blob moving one pixel per frame."""
    y, x = np.mgrid[0:H, 0:W]
    frames = [1.0 + 4.0 * np.exp(-((x - 6 - t) ** 2 + (y - 12) ** 2) / 8.0) for t in range(T)]
    return np.repeat(np.stack(frames)[..., None], 3, axis=3)


def _noisy(truth, sigma, rng):
    return truth + rng.normal(0.0, sigma, truth.shape)


def test_two_references_of_the_same_frames_score_zero_within_noise():
    """Two independent unbiased estimates, each with its per-pixel variance: the flicker of
    one against the other, less both noises, has |z| < 4 on every pair, over 20 draws."""
    rng = np.random.default_rng(1)
    truth = _truth(rng)
    sigma = 0.3
    var = np.full(truth.shape, sigma**2)
    zs = []
    for _ in range(20):
        r1, r2 = _noisy(truth, sigma, rng), _noisy(truth, sigma, rng)
        pairs = flicker(r1, var, r2[None], test_var=var)
        zs += [p.z for p in pairs]
        assert all(p.systematic == p.flicker for p in pairs)
    # 100 pairs: |z| < 4 each (the estimator's own SE; a miscalibrated one would exceed it)
    assert max(abs(z) for z in zs) < 4, zs
    assert abs(np.mean(zs)) < 0.5  # unbiased: the mean of 100 z's has SE ≈ 0.1 (pairs share frames)


def test_a_wrong_change_is_flagged():
    """Negative control: the test sequence lags the truth by one frame (a beam that pops
    late): flicker far above its SE."""
    rng = np.random.default_rng(2)
    truth = _truth(rng)
    var = np.full(truth.shape, 0.01)
    lagged = np.concatenate([truth[:1], truth[:-1]])
    pairs = flicker(_noisy(truth, 0.1, rng), var, lagged[None])
    assert min(p.z for p in pairs[1:]) > 10


def test_per_frame_noise_flickers_and_a_fixed_seed_does_not():
    """Chains with noise e: a fixed seed repeats e every frame (ΔA = Δtruth: flicker 0
    within noise); a new seed every frame gives E flicker = 2σ²·N / ΣR² (N = pixels × 3)
    per pair. With two chains the noise part is estimated, and the systematic part is 0
    within noise in both cases."""
    rng = np.random.default_rng(3)
    truth = _truth(rng)
    sigma = 0.2
    reference, var = truth, np.zeros(truth.shape)
    fixed = np.stack([truth + rng.normal(0.0, sigma, truth.shape[1:])[None] for _ in range(2)])
    moving = np.stack([_noisy(truth, sigma, rng) for _ in range(2)])
    still = flicker(reference, var, fixed)
    flicking = flicker(reference, var, moving)
    for p in still:
        assert abs(p.flicker) < 1e-12
    for p in flicking:
        expected = 2 * sigma**2 * truth[0].size / p.energy
        assert p.flicker == pytest.approx(expected, rel=0.1)  # 3456 values: the χ² mean's relative SD is 2.4%
        assert p.test_noise == pytest.approx(expected, rel=0.15)
        assert abs(p.systematic) < 4 * p.standard_error


def test_energy_jitter_by_hand():
    """Energy ratios 1, 1.1, 0.9 (the chains' mean, one chain scaled): jitters +0.1, −0.2."""
    truth = np.ones((3, 4, 4, 3))
    chains = (truth * np.array([1.0, 1.1, 0.9])[:, None, None, None])[None]
    rows = energy_jitter(truth, np.zeros_like(truth), chains)
    assert [r["energy_ratio"] for r in rows] == pytest.approx([1.0, 1.1, 0.9])
    assert np.isnan(rows[0]["jitter"]) and [r["jitter"] for r in rows[1:]] == pytest.approx([0.1, -0.2])


def test_a_dark_pair_is_undefined_not_an_error():
    """A light blocked in frames 1 and 2 (reference 0 there): those pairs and ratios are NaN,
    the others are computed (before, one dark pair left the whole component without numbers)."""
    truth = np.ones((4, 4, 4, 3))
    truth[1:3] = 0.0
    chains = (truth + 0.1)[None]
    pairs = flicker(truth, np.zeros_like(truth), chains)
    assert np.isnan(pairs[1].flicker) and np.isfinite(pairs[0].flicker) and np.isfinite(pairs[2].flicker)
    rows = energy_jitter(truth, np.zeros_like(truth), chains)
    assert np.isfinite(rows[0]["energy_ratio"]) and np.isnan(rows[1]["energy_ratio"]) and np.isnan(rows[3]["jitter"])


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="at least 2"):
        flicker(np.ones((1, 2, 2, 3)), np.ones((1, 2, 2, 3)), np.ones((1, 1, 2, 2, 3)))
    with pytest.raises(ValueError, match="shapes"):
        flicker(np.ones((2, 2, 2, 3)), np.ones((2, 2, 2, 3)), np.ones((2, 2, 2, 3)))


def test_energy_jitter_se_takes_the_references_total_variance_ratio():
    """One chain equal to the reference (no chain spread): the jitter's SE is the two
    reference totals' noise alone, √(2 · ratio · Σ var) / Σ R per channel; with a ratio of 9
    (a light tracer's covarying pixels) it is 3× the independent-pixel one (before, the
    ratio was ignored: the negative control is that 3)."""
    truth = np.ones((2, 4, 4, 3))
    var = np.full_like(truth, 1e-4)
    plain = energy_jitter(truth, var, truth[None])[1]["jitter_se"]
    scaled = energy_jitter(truth, var, truth[None], ratios=[[9.0] * 3, [9.0] * 3])[1]["jitter_se"]
    assert plain == pytest.approx(np.sqrt(2 * 16 * 1e-4) / 16, rel=1e-12)
    assert scaled == pytest.approx(3 * plain, rel=1e-12)


def _streaky_reference(rng, truth_frames, batches=16, groups=8, sd=0.15, size=5):
    """Per frame, a light-tracer-like R: ``batches`` batches of the truth whose noise each
    photon spreads over a size×size streak (the same in R, G and B), kept as the
    reference keeps them (``BatchStats`` with ``groups`` groups): (means, variances,
    groups as ``flicker``'s reference_groups take them)."""
    from volcaustics.reference.render.batches import BatchStats

    means, variances, grouped = [], [], []
    for truth in truth_frames:
        stats = BatchStats(("caustic",), groups=groups)
        for _ in range(batches):
            white = rng.standard_normal((H + size - 1, W + size - 1, 1))
            streak = sum(white[i:i + H, j:j + W] for i in range(size) for j in range(size)) / size
            stats.add({"caustic": truth + sd * streak * np.ones(3)})
        means.append(stats.mean("caustic"))
        variances.append(stats.var("caustic"))
        grouped.append((*stats.group_means("caustic"), stats.var("caustic")))
    return np.stack(means), np.stack(variances), grouped


@pytest.mark.parametrize("batches", [16, 8])  # the report's minimum, 8: one batch per group (docs/decisions.md)
def test_flicker_standard_error_sees_the_reference_pixels_covary(batches):
    """A two-frame sequence whose reference is a streaky light tracer's (its pixels covary
    over 5×5 streaks) and an approximation 5% too bright (a real flicker, so the cross
    term 4 b·Cov·b is a large part of R's): with R's batch groups the flicker's SE is
    its spread over 200 draws or a little more (spread / SE measured 0.68–0.74 over 300
    draws, two seeds: the delete-one-group jackknife overstates the noise×noise part, as
    "Jackknife calibration" in docs/decisions.md says; 0.88 at 20% too bright). Bounds
    0.55–1.1: ±5% sampling error of the spread about the measured values, and an SE too
    small (a false alarm risk) fails. With the independent-pixel formula the spread is
    3.4–3.7× its SE (the negative control: the gate would flag R's noise as flicker)."""
    rng = np.random.default_rng(37)
    truth = _truth(rng)[:2]
    values, grouped, independent = [], [], []
    for _ in range(200):
        reference, var, groups = _streaky_reference(rng, truth, batches=batches)
        chains = (1.05 * truth + rng.normal(0.0, 0.02, (2, *truth.shape)))
        with_groups = flicker(reference, var, chains, reference_groups=groups)[0]
        values.append(with_groups.flicker)
        grouped.append(with_groups.standard_error)
        independent.append(flicker(reference, var, chains)[0].standard_error)
    spread = np.std(values, ddof=1)
    ratio = spread / np.sqrt(np.mean(np.square(grouped)))
    print(f"{batches} batches: spread / SE {ratio:.3f}, independent pixels "
          f"{spread / np.sqrt(np.mean(np.square(independent))):.2f}")
    assert 0.55 < ratio < 1.1, ratio
    assert spread / np.sqrt(np.mean(np.square(independent))) > 3
