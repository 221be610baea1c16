"""metrics.decomposition on synthetic paired batch images whose split is known:
telescoping identities on random images, constructed ladders with shares known in
closed form (per channel), the identity (also with K not a power of 2), a residual
that noise explains and one it does not, the noise row, the compared pixels, bad
input, and the jackknife standard errors against the spread over many independent
draws — including a term whose two images share their photons."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.metrics.decomposition import BATCHED, IMAGES, TERMS, caustic_terms, decompose_caustic
from volcaustics.metrics.image import energy_ratio, relative_mse

H, W, K = 16, 16, 16
ALL_TERMS = tuple(TERMS)
FIELDS = ("energy_share", "relmse_part", "relmse_own")


def _truth():
    """A smooth caustic-like image, well above 0 everywhere (H×W×3, linear)."""
    y, x = np.mgrid[0:H, 0:W]
    blob = np.exp(-((x - 7.0) ** 2 + (y - 9.0) ** 2) / 20.0)
    return np.stack([0.5 + blob, 0.4 + 0.8 * blob, 0.3 + 0.5 * blob], axis=-1)


def _noiseless(images, k=K):
    """Paired batches that are all equal to their image: k copies of each."""
    return {name: np.stack([np.asarray(images[name], np.float64)] * k) for name in BATCHED}


def _row(result, term):
    (row,) = [r for r in result["rows"] if r["term"] == term]
    return row


def _blurred_noise(rng, shape, sd, size=3, channels=None):
    """Noise shared by neighbouring pixels, as one splat over size×size pixels gives:
    per-pixel standard deviation ``sd``, correlated over a size×size box (``channels``
    1: the same in R, G and B, as one photon's)."""
    c = shape[-1] if channels is None else channels
    white = rng.standard_normal((*shape[:-3], shape[-3] + size - 1, shape[-2] + size - 1, c))
    box = sum(white[..., i:i + shape[-3], j:j + shape[-2], :] for i in range(size) for j in range(size))
    return sd * box / size * np.ones(shape[-1])  # the sum of size² unit normals has sd size


def _photon_noise(rng, shape, sd):
    """Reference noise as one photon gives it: the same normal in R, G and B of a
    pixel (the module adds the channels' σ, assuming this), independent pixels."""
    return sd * rng.standard_normal(shape[:-1])[..., None] * np.ones(shape[-1])


# --- identities ----------------------------------------------------------------------


def test_terms_telescope_to_the_total_error():
    """On unrelated random batches the six terms still sum to R − A pixel by pixel,
    their energy shares to 1 − the energy ratio (``metrics.image``, RGB mean) and
    their relMSE parts to the relative MSE (``metrics.image``)."""
    rng = np.random.default_rng(10)
    batches = {name: rng.uniform(0.1, 2.0, (K, H, W, 3)) for name in BATCHED}
    reference = rng.uniform(0.1, 2.0, (H, W, 3))
    keep = rng.random((H, W)) < 0.7
    result = decompose_caustic(batches, reference, keep=keep)

    images = result["images"]
    assert set(images) == set(IMAGES)
    for name in BATCHED:
        np.testing.assert_array_equal(images[name], batches[name].mean(axis=0))
    np.testing.assert_array_equal(images["reference"], reference)
    r, a = reference, images["approx"]
    terms = caustic_terms(images)
    assert set(terms) == set(ALL_TERMS) == set(result["terms"])
    np.testing.assert_allclose(sum(terms.values()), r - a, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sum(result["terms"].values()), r - a, rtol=0, atol=1e-12)

    total = _row(result, "total")
    per_channel = 1 - a[keep].sum(axis=0) / r[keep].sum(axis=0)
    assert total["energy_share"] == pytest.approx(per_channel.mean(), rel=0, abs=1e-12)
    assert total["energy_share"] == pytest.approx(1 - energy_ratio(r, a, mask=keep)["mean"], rel=0, abs=1e-12)
    assert total["relmse_part"] == pytest.approx(relative_mse(r, a, mask=keep), rel=1e-12)
    assert total["relmse_own"] == pytest.approx(total["relmse_part"], rel=1e-12)  # the total's part is itself
    assert sum(_row(result, t)["energy_share"] for t in ALL_TERMS) == pytest.approx(total["energy_share"], abs=1e-12)
    assert sum(_row(result, t)["relmse_part"] for t in ALL_TERMS) == pytest.approx(total["relmse_part"], rel=1e-12)
    for t in ALL_TERMS:  # each term's own relMSE from its image
        own = np.sum(result["terms"][t][keep] ** 2) / np.sum(r[keep] ** 2)
        assert _row(result, t)["relmse_own"] == pytest.approx(own, rel=1e-12)
    for row in result["rows"][:-1]:  # every term and the total carry finite, non-negative SEs
        for field in FIELDS:
            assert np.isfinite(row[f"{field}_se"]) and row[f"{field}_se"] >= 0, (row["term"], field)
    assert [row["term"] for row in result["rows"]] == [*ALL_TERMS, "total", "noise"]
    assert set(_row(result, "noise")) == {"term", "energy_sigma", "relmse"}
    assert result["options"]["pixels"] == int(keep.sum()) and result["options"]["batches"] == K


def test_constructed_ladder_has_known_shares():
    """R = 1 everywhere and noiseless batches (so every jackknife SE is 0):
    E_∞,s,τ = R; E_∞,s = E_em = 0.9 R; E_∞ = 0.8 R; E_∞(same) = 0.7 R; E_k = 0.6 R;
    A_m = 0.5 R; A = 0.4 R. Each of camera_volume, emission, reflections, truncation,
    intersection and march closes 0.1 of the energy; blur and residual are 0. relMSE
    parts: term · (R − A) / R² = 0.1 · 0.6 = 0.06; own: 0.1² = 0.01."""
    one = np.ones((H, W, 3))
    images = {"exact_all_small_eye": one, "exact_all_small": 0.9 * one, "exact_emission": 0.9 * one,
              "exact_all": 0.8 * one, "exact_all_same": 0.7 * one, "exact_steps": 0.6 * one,
              "approx_exact_march": 0.5 * one, "approx": 0.4 * one}
    result = decompose_caustic(_noiseless(images, 8), one)
    expected = {"emission": 0.1, "march": 0.1, "intersection": 0.1, "truncation": 0.1, "reflections": 0.1,
                "kernel_blur": 0.0, "camera_volume": 0.1, "residual": 0.0}
    assert set(expected) == set(TERMS)
    for term, share in expected.items():
        row = _row(result, term)
        assert row["energy_share"] == pytest.approx(share, abs=1e-12), term
        assert row["relmse_part"] == pytest.approx(share * 0.6, abs=1e-12), term
        assert row["relmse_own"] == pytest.approx(share**2, abs=1e-12), term
        for field in FIELDS:
            assert row[f"{field}_se"] == 0.0, (term, field)
        np.testing.assert_allclose(result["terms"][term], share * one, rtol=0, atol=1e-12)
    total = _row(result, "total")
    assert total["energy_share"] == pytest.approx(0.6, abs=1e-12)
    assert total["relmse_part"] == pytest.approx(0.36, abs=1e-12)
    assert all(total[f"{field}_se"] == 0.0 for field in FIELDS)
    noise = _row(result, "noise")  # A's batch variance is rounding only (0.4 is not exact in binary)
    assert noise["energy_sigma"] == 0.0 and noise["relmse"] == pytest.approx(0.0, abs=1e-12)
    residual = result["residual"]
    assert residual["energy_share"] == 0.0 and residual["debiased_relmse"] == 0.0
    assert residual["energy_se"] == 0.0 and residual["relmse_se"] == 0.0
    assert residual["within_noise"] and residual["message"] == ""


def test_energy_shares_are_per_channel_averaged_over_rgb():
    """Channels of very different energy (R ∝ 1, 10, 100) and A = R × (0.9, 0.7, 0.5):
    the shares are mean(0.1, 0.3, 0.5) = 0.3, where a share of the pooled energy
    would be (0.1 + 3 + 50) / 111 ≈ 0.48."""
    r = _truth() * np.array([1.0, 10.0, 100.0])
    images = {name: r for name in BATCHED}
    images["approx"] = images["approx_exact_march"] = r * np.array([0.9, 0.7, 0.5])
    result = decompose_caustic(_noiseless(images, 4), r)
    assert _row(result, "total")["energy_share"] == pytest.approx(0.3, abs=1e-12)
    assert _row(result, "intersection")["energy_share"] == pytest.approx(0.3, abs=1e-12)
    for t in ALL_TERMS:
        if t != "intersection":
            assert _row(result, t)["energy_share"] == pytest.approx(0.0, abs=1e-12), t


@pytest.mark.parametrize("k", [4, 5, 7, 12])
def test_identity_is_zero_and_within_noise(k):
    """Error of X with X, noiseless: every term is 0 and the residual is within noise,
    whatever the number of (identical) batches. When K is not a power of 2 their mean
    — and the mean of the K delete-one values — differ from X in the last bit: a
    rounding residual (~1e-18) against a rounding standard error (~1e-34) is no
    disagreement. Five images, as the last bit depends on the values."""
    for seed in range(11, 16):
        x = np.random.default_rng(seed).uniform(0.1, 2.0, (H, W, 3))
        result = decompose_caustic(_noiseless({name: x for name in BATCHED}, k), x)
        for t in ALL_TERMS:
            np.testing.assert_allclose(result["terms"][t], 0.0, rtol=0, atol=1e-12)
            for field in FIELDS:
                assert _row(result, t)[field] == pytest.approx(0.0, abs=1e-12), (t, field)
        total = _row(result, "total")
        assert total["energy_share"] == pytest.approx(0.0, abs=1e-12)
        assert total["relmse_part"] == pytest.approx(0.0, abs=1e-12)
        residual = result["residual"]
        assert residual["within_noise"], (k, seed, residual)
        assert residual["message"] == ""


def test_noisy_identity_is_zero_and_within_noise():
    """Every image is the same noisy paired batches and R is their mean: every term is
    0, and the residual, whose standard error is now a real one, is within noise."""
    rng = np.random.default_rng(17)
    batches = _truth() + _blurred_noise(rng, (K, H, W, 3), 0.05)
    result = decompose_caustic({name: batches for name in BATCHED}, batches.mean(axis=0))
    for t in ALL_TERMS:
        np.testing.assert_allclose(result["terms"][t], 0.0, rtol=0, atol=1e-12)
    assert _row(result, "total")["energy_share"] == 0.0
    assert _row(result, "total")["energy_share_se"] > 0  # A's noise
    residual = result["residual"]
    assert residual["energy_share"] == pytest.approx(0.0, abs=1e-12) and residual["energy_se"] > 0
    assert residual["within_noise"] and residual["message"] == ""


# --- the residual against noise ----------------------------------------------------


def test_a_wrong_reference_is_flagged():
    """R = 1.2 × the truth, every batch the truth with noise 0.01 (paired): a 1/6
    energy gap against a standard error of ~1e-4 must not pass as noise."""
    rng = np.random.default_rng(12)
    truth = _truth()
    batches = truth + _blurred_noise(rng, (K, H, W, 3), 0.01)
    result = decompose_caustic({name: batches for name in BATCHED}, 1.2 * truth)
    residual = result["residual"]
    assert not residual["within_noise"]
    assert "disagree" in residual["message"]
    assert residual["energy_share"] == pytest.approx(1 - 1 / 1.2, abs=1e-3)
    assert residual["energy_share"] == pytest.approx(_row(result, "total")["energy_share"], abs=1e-12)
    assert residual["energy_z"] > 100 and residual["relmse_z"] > 100


@pytest.mark.parametrize("reference_noise", [False, True])
def test_an_unbiased_residual_is_within_noise(reference_noise):
    """Paired batches (K = 16, correlated over neighbours) and, in one variant, R too
    are noisy around one truth: the residual is pure noise. Each of its two z-scores
    exceeds the limit 3 for about 1% of draws or fewer (normal: 0.27%; the energy's
    jackknife SE from 16 batches makes its z a t with 15 degrees of freedom: 0.9%;
    the jackknife of the quadratic debiased relMSE errs on the large side), so over
    20 independent draws at most 2 false alarms is a generous bound (P(≥ 3 of 20) <
    0.1% at a 2% rate per draw)."""
    truth = _truth()
    passed = 0
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        noise = _blurred_noise(rng, (K, H, W, 3), 0.02)
        batches = {name: f * truth + noise for name, f in zip(BATCHED, (0.6, 0.7, 0.8, 0.9, 0.95, 0.97, 0.99, 1.0))}
        kwargs, reference = {}, truth
        if reference_noise:
            kwargs["reference_var"] = np.full_like(truth, 0.005**2)
            reference = truth + _photon_noise(rng, truth.shape, 0.005)
        residual = decompose_caustic(batches, reference, **kwargs)["residual"]
        passed += residual["within_noise"]
        assert residual["within_noise"] == (residual["message"] == "")
    assert passed >= 18


def _stratified(rng, truth, seeds=4, subsets=8, spread=0.05, sd=0.01):
    """Batches as the experiment makes them: seeds × subsets, seed-major; subset b holds
    the same texels in every seed, so it is off the mean by a fixed pattern of its own
    (``spread``: what its texels alone make; the patterns sum to 0) plus noise (``sd``,
    new in every seed)."""
    offsets = _blurred_noise(rng, (subsets, H, W, 3), spread)
    offsets -= offsets.mean(axis=0)
    noise = _blurred_noise(rng, (seeds, subsets, H, W, 3), sd)
    batches = (truth + offsets + noise).reshape(seeds * subsets, H, W, 3)
    return {name: batches for name in BATCHED}


def test_subsets_that_differ_by_their_texels_are_not_noise():
    """Subsets whose means differ by their texels alone (5× the noise): with ``subsets``
    the residual of an unbiased R is within noise in at least 18 of 20 draws (the bound
    of test_an_unbiased_residual_is_within_noise), and its z is spread as noise
    (sd ≤ 1.5: the jackknife errs on the large side); taken as independent batches (the
    old estimate, subsets None) the texels' spread counts as noise the mean does not
    have, and the relMSE's z falls below −3 every time."""
    truth = _truth()
    within, z, independent = 0, [], []
    for seed in range(20):
        rng = np.random.default_rng(300 + seed)
        batches = _stratified(rng, truth)
        var = np.full_like(truth, 0.002**2)
        reference = truth + _photon_noise(rng, truth.shape, 0.002)
        residual = decompose_caustic(batches, reference, reference_var=var, subsets=8)["residual"]
        within += residual["within_noise"] and abs(residual["relmse_z"]) <= 3
        z += [residual["energy_z"], residual["relmse_z"]]
        independent.append(decompose_caustic(batches, reference, reference_var=var)["residual"]["relmse_z"])
    assert within >= 18
    assert np.std(z) <= 1.5
    assert max(independent) < -3


def test_a_biased_residual_is_caught_within_subsets():
    """The negative control of the strata: the same batches against an R 3% brighter in
    a blob (a renderer that disagrees) leave the noise on both z-scores."""
    truth = _truth()
    rng = np.random.default_rng(7)
    batches = _stratified(rng, truth)
    y, x = np.mgrid[0:H, 0:W]
    reference = truth * (1 + 0.03 * np.exp(-((x - 7.0) ** 2 + (y - 9.0) ** 2) / 8.0))[..., None]
    residual = decompose_caustic(batches, reference, reference_var=np.full_like(truth, 0.002**2),
                                 subsets=8)["residual"]
    assert residual["energy_z"] > 3 and residual["relmse_z"] > 3 and not residual["within_noise"]


def test_subsets_must_divide_the_batches():
    batches = _stratified(np.random.default_rng(1), _truth(), seeds=2, subsets=8)
    with pytest.raises(ValueError, match="subsets: 5"):
        decompose_caustic(batches, _truth(), subsets=5)


def test_noise_row_is_what_noise_alone_explains():
    """A and R both unbiased (A's batches white noise of sd 0.3 per batch, R's of sd
    0.02): the total relMSE is noise, and the noise row's relMSE, (Σ var_R + Σ s²_A/K)
    / Σ R², predicts it. Its expectation is Σ(var_R + σ²/K); one draw over 768 values
    has a relative sd of √(2/768) ≈ 5% (the estimated s² adds ~1%): 20% is 4 of
    them. The energy σ is the total's energy SE."""
    rng = np.random.default_rng(18)
    truth = _truth()
    approx = truth + 0.3 * rng.standard_normal((K, H, W, 3))
    batches = {name: approx for name in BATCHED}
    var = np.full_like(truth, 0.02**2)
    reference = truth + 0.02 * rng.standard_normal(truth.shape)
    result = decompose_caustic(batches, reference, reference_var=var)
    noise, total = _row(result, "noise"), _row(result, "total")
    energy = np.sum(reference**2)
    assert noise["relmse"] == pytest.approx((var.sum() + approx.var(axis=0, ddof=1).sum() / K) / energy, rel=1e-12)
    assert noise["relmse"] == pytest.approx(truth.size * (0.02**2 + 0.3**2 / K) / energy, rel=0.2)
    assert total["relmse_part"] == pytest.approx(noise["relmse"], rel=0.2)
    assert noise["energy_sigma"] == total["energy_share_se"] > 0


# --- the compared pixels and bad input ---------------------------------------------


def test_pixels_outside_keep_change_nothing():
    rng = np.random.default_rng(13)
    batches = {name: rng.uniform(0.1, 2.0, (K, H, W, 3)) for name in BATCHED}
    reference = rng.uniform(0.1, 2.0, (H, W, 3))
    var = rng.uniform(0.0, 1e-3, (H, W, 3))
    keep = np.ones((H, W), bool)
    keep[:, :5] = False
    keep[3, 9] = False
    before = decompose_caustic(batches, reference, keep=keep, reference_var=var)
    outside = int((~keep).sum())
    garbage = {name: b.copy() for name, b in batches.items()}
    for b in garbage.values():
        b[:, ~keep] = rng.uniform(0.0, 100.0, (K, outside, 3))
    reference2, var2 = reference.copy(), var.copy()
    reference2[~keep] = rng.uniform(0.0, 100.0, (outside, 3))
    var2[~keep] = 5.0
    after = decompose_caustic(garbage, reference2, keep=keep, reference_var=var2)
    assert after["rows"] == before["rows"]
    assert after["residual"] == before["residual"]
    assert after["options"] == before["options"]
    for name in IMAGES:  # the returned images are whole, and equal where compared
        np.testing.assert_array_equal(after["images"][name][keep], before["images"][name][keep])
    # and the garbage does matter when every pixel is compared
    assert decompose_caustic(garbage, reference2)["rows"] != decompose_caustic(batches, reference)["rows"]


BAD_INPUTS = ["missing", "unpaired_shape", "channels", "not_batched", "too_few_batches", "keep_none",
              "keep_shape", "zero_reference_channel", "reference_shape", "batch_not_finite",
              "reference_not_finite", "reference_var_shape", "reference_var_negative"]


@pytest.mark.parametrize("bad", BAD_INPUTS)
def test_bad_input_raises_value_error(bad):
    rng = np.random.default_rng(14)
    batches = {name: rng.uniform(0.1, 2.0, (K, H, W, 3)) for name in BATCHED}
    reference, kwargs = rng.uniform(0.1, 2.0, (H, W, 3)), {}
    if bad == "missing":
        del batches["exact_steps"]
    elif bad == "unpaired_shape":  # a different number of batches than approx's
        batches["exact_all"] = batches["exact_all"][:-1]
    elif bad == "channels":
        batches["exact_all"] = batches["exact_all"][..., :2]
    elif bad == "not_batched":
        batches = {name: b.mean(axis=0) for name, b in batches.items()}
    elif bad == "too_few_batches":
        batches = {name: b[:3] for name, b in batches.items()}
    elif bad == "keep_none":
        kwargs["keep"] = np.zeros((H, W), bool)
    elif bad == "keep_shape":
        kwargs["keep"] = np.ones((H, W + 1), bool)
    elif bad == "zero_reference_channel":
        reference[..., 2] = 0.0
    elif bad == "reference_shape":
        reference = reference[:-1]
    elif bad == "batch_not_finite":
        batches["approx"][2, 3, 1, 0] = np.nan
    elif bad == "reference_not_finite":
        reference[3, 4, 2] = np.inf
    elif bad == "reference_var_shape":  # H×W: one variance per pixel, not per channel
        kwargs["reference_var"] = np.full((H, W), 1e-3)
    else:
        kwargs["reference_var"] = np.full((H, W, 3), -1e-3)
    with pytest.raises(ValueError):
        decompose_caustic(batches, reference, **kwargs)


def test_caustic_terms_names_the_missing_image():
    rng = np.random.default_rng(15)
    images = {name: rng.uniform(0.1, 2.0, (H, W, 3)) for name in IMAGES}
    del images["exact_all_same"]
    with pytest.raises(ValueError, match="exact_all_same"):
        caustic_terms(images)


# --- standard errors ---------------------------------------------------------------


def test_jackknife_standard_error_matches_the_spread_over_draws():
    """Paired batches as photons give them: noise N_k (blurred, shared by neighbours)
    in E_∞,s = truth + N_k, E_em = E_∞ = 0.97 E_∞,s + its own noise M_k (another kernel),
    E_∞(same) = 0.9 E_∞, E_k = 0.95 E_∞(same), A = 0.9 E_k — the same photons in
    every batch k — and R = 1.05 truth with its own noise, redrawn each draw.

    The intersection E_k − A = 0.1 E_k carries a tenth of E_k's noise: its SE must
    be that small, not what two independent images would have (√(1 + 0.9²) × E_k's,
    ~13× more). Over 200 independent draws the spread of each number must match its
    stated SE (root mean square over the draws, since the jackknife estimates the
    variance): the sample standard deviation of 200 draws has a relative sampling
    error of 1/√(2·199) ≈ 5%, the RMS of 200 SEs (each from K = 8 batches, ~7 degrees
    of freedom) about 2%; 0.7–1.4 is over 6 of those standard errors either way and
    leaves room for the jackknife's own small-sample bias. The total and the residual
    include R's noise (the same in R, G and B, as one photon's), the others do not."""
    rng = np.random.default_rng(16)
    truth = _truth()
    k, ref_sd = 8, 0.02
    var = np.full_like(truth, ref_sd**2)
    checked = [("intersection", f) for f in FIELDS] + [("kernel_blur", f) for f in FIELDS] + [
        ("total", "energy_share"), ("total", "relmse_part"), ("residual", "energy_share")]
    values = {key: [] for key in checked}
    errors = {key: [] for key in checked}
    independent_se = []
    for _ in range(200):
        small = truth + _blurred_noise(rng, (k, H, W, 3), 0.05)
        full = 0.97 * small + _blurred_noise(rng, (k, H, W, 3), 0.02)
        same = 0.9 * full
        steps = 0.95 * same
        approx = 0.9 * steps
        batches = {"exact_all_small_eye": small, "exact_all_small": small, "exact_emission": full,
                   "exact_all": full, "exact_all_same": same, "exact_steps": steps, "approx_exact_march": approx,
                   "approx": approx}
        reference = 1.05 * truth + _photon_noise(rng, truth.shape, ref_sd)
        result = decompose_caustic(batches, reference, reference_var=var)
        for term, field in checked:
            row = _row(result, term)
            values[term, field].append(row[field])
            errors[term, field].append(row[f"{field}_se"])
        # E_k's and A's energy shares alone, each with its SE over the batches, as if independent
        channel_energy = reference.sum(axis=(0, 1))
        share_se = [np.std((b.sum(axis=(1, 2)) / channel_energy).mean(axis=1), ddof=1) / np.sqrt(k)
                    for b in (steps, approx)]
        independent_se.append(np.hypot(*share_se))
        assert result["residual"]["within_noise"] == (result["residual"]["message"] == "")
    for key in checked:
        ratio = np.std(values[key], ddof=1) / np.sqrt(np.mean(np.square(errors[key])))
        assert 0.7 < ratio < 1.4, f"{key}: spread / stated SE = {ratio:.2f}"
    # shared photons: the intersection's SE is a tenth of E_k's, far below independent images'
    intersection_se = np.mean(errors["intersection", "energy_share"])
    assert intersection_se < 0.15 * np.mean(independent_se)
    # and the blur itself (E_∞,s − E_∞ = 0.03 truth) is found within its noise
    shares = values["kernel_blur", "energy_share"]
    assert np.mean(shares) == pytest.approx(0.03 / 1.05, abs=4 * np.std(shares) / np.sqrt(200))


def _streaky_draw(rng, truth, brightness=1.0, batches=16):
    """Paired exact batches near ``truth`` and a light-tracer-like R: ``batches`` batches of
    ``brightness`` × truth whose noise each photon spreads over a 5×5 streak (the same in
    R, G and B), kept as the reference keeps them (``BatchStats``, 8 groups)."""
    from volcaustics.reference.render.batches import BatchStats

    exact = truth + _blurred_noise(rng, (K, H, W, 3), 0.002)
    stats = BatchStats(("caustic",), groups=8)
    for noise in _blurred_noise(rng, (batches, H, W, 3), 0.05, size=5, channels=1):
        stats.add({"caustic": brightness * truth + noise})
    return {name: exact for name in BATCHED}, stats


@pytest.mark.parametrize("reference_batches", [16, 8])  # the report's minimum, 8: one per group (docs/decisions.md)
def test_residual_energy_standard_error_sees_the_reference_pixels_covary(reference_batches):
    """R as a light tracer gives it: the mean of 16 batches whose noise each photon
    spreads over a 5×5 streak (the same in R, G and B), so R's pixels covary and Σ var
    understates the variance of its total ~25-fold. From the batches' own totals
    (``BatchStats``, as the reference keeps them) the ratio is measured and the
    residual's energy SE must match its spread over 200 draws (bounds as in the test
    above); without it, the SE is the independent-pixel one, several times too small
    (the negative control: the residual would be flagged for R's noise alone)."""
    from volcaustics.reference.render.batches import total_variance_ratio

    rng = np.random.default_rng(25)
    truth = _truth()
    values, with_ratio, without = [], [], []
    for _ in range(200):
        batches, stats = _streaky_draw(rng, truth, batches=reference_batches)
        reference, var = stats.mean("caustic"), stats.var("caustic")
        ratio = total_variance_ratio((stats, "caustic"))
        result = decompose_caustic(batches, reference, reference_var=var, reference_ratio=ratio)
        values.append(result["residual"]["energy_share"])
        with_ratio.append(result["residual"]["energy_se"])
        without.append(decompose_caustic(batches, reference, reference_var=var)["residual"]["energy_se"])
    spread = np.std(values, ddof=1)
    print(f"{reference_batches} batches: spread / SE {spread / np.sqrt(np.mean(np.square(with_ratio))):.3f}")
    assert 0.7 < spread / np.sqrt(np.mean(np.square(with_ratio))) < 1.4
    assert spread / np.sqrt(np.mean(np.square(without))) > 3


@pytest.mark.parametrize("reference_batches", [16, 8])  # the report's minimum, 8: one per group (docs/decisions.md)
def test_residual_relmse_standard_error_sees_the_reference_pixels_covary(reference_batches):
    """The same streaky R, 3% brighter than the exact photons (a real residual, so the
    cross term 2 Σ d·n dominates R's part): its 16 batches in 8 groups, and the residual's
    debiased relMSE SE from the delete-one-group jackknife matches the spread over 200
    draws (0.7–1.4; measured 1.01 over 300). The independent-pixel √(2 Σ var²) is ~17×
    too small (the negative control); in pure noise the jackknife errs large (measured
    spread / SE 0.69: the Efron–Stein bias, as for E's batches)."""
    rng = np.random.default_rng(26)
    truth = _truth()
    values, grouped, independent = [], [], []
    for _ in range(200):
        batches, stats = _streaky_draw(rng, truth, 1.03, batches=reference_batches)
        reference, var = stats.mean("caustic"), stats.var("caustic")
        residual = decompose_caustic(batches, reference, reference_var=var,
                                     reference_groups=stats.group_means("caustic"))["residual"]
        values.append(residual["debiased_relmse"])
        grouped.append(residual["relmse_se"])
        independent.append(decompose_caustic(batches, reference, reference_var=var)["residual"]["relmse_se"])
    spread = np.std(values, ddof=1)
    print(f"{reference_batches} batches: spread / SE {spread / np.sqrt(np.mean(np.square(grouped))):.3f}")
    assert 0.7 < spread / np.sqrt(np.mean(np.square(grouped))) < 1.4
    assert spread / np.sqrt(np.mean(np.square(independent))) > 5


@pytest.mark.parametrize("reference_noise", [False, True])
def test_residual_relmse_standard_error_matches_the_spread_when_unbiased(reference_noise):
    """The residual is pure noise (E_∞,s's K = 8 paired batches around the truth and,
    in one variant, R too, with its variance given): over 200 independent draws the
    spread of the debiased relMSE must match its stated SE (RMS over the draws) as the
    analysis says, and its mean must be 0 within 4 standard errors of the mean (the
    debiasing is exact). Pure noise makes the debiased relMSE a degenerate U-statistic,
    whose delete-one jackknife variance overstates the noise×noise part by
    2(K−1)/(K−2) (Efron–Stein): spread / SE ≈ √((K−2)/(2(K−1))) = 0.65 at K = 8, a bit
    more with R's noise (its part is analytic). So the ratio must lie in 0.55–0.85
    (±5% sampling error of the spread, and room for R's share): the test is
    conservative, an SE too large by f makes the limit of 3 one of 3f true σ; the
    bound catches an SE that is too small (a false alarm risk) or grows further."""
    rng = np.random.default_rng(19)
    truth = _truth()
    k, ref_sd = 8, 0.005
    estimates, errors = [], []
    for _ in range(200):
        batches = truth + _blurred_noise(rng, (k, H, W, 3), 0.02)
        kwargs, reference = {}, truth
        if reference_noise:
            kwargs["reference_var"] = np.full_like(truth, ref_sd**2)
            reference = truth + ref_sd * rng.standard_normal(truth.shape)
        residual = decompose_caustic({name: batches for name in BATCHED}, reference, **kwargs)["residual"]
        estimates.append(residual["debiased_relmse"])
        errors.append(residual["relmse_se"])
    spread = np.std(estimates, ddof=1)
    assert np.mean(estimates) == pytest.approx(0.0, abs=4 * spread / np.sqrt(200))
    ratio = spread / np.sqrt(np.mean(np.square(errors)))
    assert 0.55 < ratio < 0.85, f"spread / stated SE = {ratio:.2f}"


def test_debiased_parts_remove_the_noise_a_term_shares_with_the_error():
    """Every exact image is A's photons (the same noise) and R the truth: the error is
    pure noise. The raw parts carry it (the residual's, R − E_∞,s, shares E_∞,s's noise
    with A's: its raw part is far from 0, the negative control), the debiased parts do
    not: each within 4 SE of 0 (tolerance: 4 jackknife SE), and they sum to the total's,
    the relative MSE less A's variance of the mean."""
    rng = np.random.default_rng(21)
    truth = _truth()
    noise = _blurred_noise(rng, (K, H, W, 3), 0.05)
    batches = {name: truth + noise for name in BATCHED}
    result = decompose_caustic(batches, truth)
    residual, total = _row(result, "residual"), _row(result, "total")
    assert residual["relmse_part"] > 4 * residual["relmse_part_se"]
    for term in ALL_TERMS:
        row = _row(result, term)
        assert abs(row["relmse_part_debiased"]) <= 4 * row["relmse_part_se"] + 1e-15, term
    a = batches["approx"]
    debiased_total = (np.sum((truth - a.mean(axis=0)) ** 2) - a.var(axis=0, ddof=1).sum() / K) / np.sum(truth**2)
    assert total["relmse_part_debiased"] == pytest.approx(debiased_total, rel=1e-9)
    assert sum(_row(result, t)["relmse_part_debiased"] for t in ALL_TERMS) == pytest.approx(
        total["relmse_part_debiased"], rel=1e-9)


@pytest.mark.parametrize("reference_batches", [16, 8])  # the report's minimum, 8: one per group (docs/decisions.md)
def test_relmse_parts_standard_errors_see_the_reference_pixels_covary(reference_batches):
    """R enters the total's and the residual's parts of the relative MSE (Σ(R − A)²,
    Σ(R − E_∞,s)(R − A)): with A 20% below the truth, R's streaky noise times the large
    error R − A is most of their noise. With R's batch groups their SEs match the spread
    over 200 draws or err large (spread / SE measured, two seeds: residual 0.88–0.94,
    total 0.72–0.77, whose quadratic noise part the jackknife overstates; bounds
    0.6–1.4); with independent pixels the spread is 5.7–7.1× the SE (the negative control:
    the residual's part would look significant on R's noise alone)."""
    rng = np.random.default_rng(27)
    truth = _truth()
    values, grouped, independent = {t: [] for t in ("total", "residual")}, {"total": [], "residual": []}, \
        {"total": [], "residual": []}
    for _ in range(200):
        batches, stats = _streaky_draw(rng, truth, 1.03, batches=reference_batches)
        batches = {**batches, "approx": 0.8 * batches["approx"]}
        reference, var = stats.mean("caustic"), stats.var("caustic")
        with_groups = decompose_caustic(batches, reference, reference_var=var,
                                        reference_groups=stats.group_means("caustic"))
        without = decompose_caustic(batches, reference, reference_var=var)
        for term in values:
            values[term].append(_row(with_groups, term)["relmse_part_debiased"])
            grouped[term].append(_row(with_groups, term)["relmse_part_se"])
            independent[term].append(_row(without, term)["relmse_part_se"])
    for term in values:
        spread = np.std(values[term], ddof=1)
        ratio = spread / np.sqrt(np.mean(np.square(grouped[term])))
        print(f"{reference_batches} batches, {term}: spread / SE {ratio:.3f}")
        assert 0.6 < ratio < 1.4, (term, ratio)
        assert spread / np.sqrt(np.mean(np.square(independent[term]))) > 3, term


def test_aliased_images_give_the_numbers_their_copies_give():
    """A homogeneous medium passes A_m as A's array and E_∞,s,τ as E_∞,s's (computed once
    each, ``_once``): the result is the one equal copies give, to the last bit."""
    rng = np.random.default_rng(41)
    batches = {name: rng.uniform(0.1, 2.0, (K, H, W, 3)) for name in BATCHED}
    batches["approx_exact_march"] = batches["approx"]
    batches["exact_all_small_eye"] = batches["exact_all_small"]
    copies = {name: b.copy() for name, b in batches.items()}
    reference = rng.uniform(0.1, 2.0, (H, W, 3))
    aliased, copied = decompose_caustic(batches, reference), decompose_caustic(copies, reference)
    assert aliased["rows"] == copied["rows"] and aliased["residual"] == copied["residual"]
