"""metrics.decomposition on synthetic images whose split is known: telescoping
identities on random images, a constructed ladder of images with shares known in
closed form, the identity, a residual that noise explains and one it does not, the
compared pixels, bad input, and the jackknife standard errors against the spread
over many independent draws."""

from __future__ import annotations

import numpy as np
import pytest

from metrics.decomposition import IMAGES, TERMS, caustic_terms, decompose_caustic

H, W, K = 16, 16, 16
FIVE = tuple(TERMS)


def _truth():
    """A smooth caustic-like image, well above 0 everywhere (H×W×3, linear)."""
    y, x = np.mgrid[0:H, 0:W]
    blob = np.exp(-((x - 7.0) ** 2 + (y - 9.0) ** 2) / 20.0)
    return np.stack([0.5 + blob, 0.4 + 0.8 * blob, 0.3 + 0.5 * blob], axis=-1)


def _random_images(rng):
    """Six unrelated positive images named as IMAGES (the given E_∞,s is replaced
    by the batches' mean inside ``decompose_caustic``)."""
    return {name: rng.uniform(0.1, 2.0, (H, W, 3)) for name in IMAGES}


def _row(result, term):
    (row,) = [r for r in result["rows"] if r["term"] == term]
    return row


def _blurred_noise(rng, shape, sd):
    """Noise shared by neighbouring pixels, as one splat over 3×3 pixels gives:
    per-pixel standard deviation ``sd``, correlated over a 3×3 box."""
    white = rng.standard_normal((*shape[:-3], shape[-3] + 2, shape[-2] + 2, shape[-1]))
    box = sum(white[..., i:i + shape[-3], j:j + shape[-2], :] for i in range(3) for j in range(3))
    return sd * box / 3.0  # the sum of 9 unit normals has sd 3


# --- identities ----------------------------------------------------------------------


def test_terms_telescope_to_the_total_error():
    """On unrelated random images the five terms still sum to R − A pixel by pixel,
    their energy shares to 1 − ΣA/ΣR and their relMSE parts to Σ(R − A)²/ΣR²."""
    rng = np.random.default_rng(10)
    images = _random_images(rng)
    batches = rng.uniform(0.1, 2.0, (K, H, W, 3))
    keep = rng.random((H, W)) < 0.7
    terms = caustic_terms(images)
    assert set(terms) == set(FIVE)
    np.testing.assert_allclose(sum(terms.values()), images["reference"] - images["approx"], rtol=0, atol=1e-12)

    result = decompose_caustic(images, batches, keep=keep)
    np.testing.assert_allclose(sum(result["terms"].values()), images["reference"] - images["approx"],
                               rtol=0, atol=1e-12)
    np.testing.assert_array_equal(result["images"]["exact_all_small"], batches.mean(axis=0))
    r, a = images["reference"][keep], images["approx"][keep]
    total = _row(result, "total")
    # the channel weights are equal, so the RGB-averaged ratio is that of the sums over all channels
    assert total["energy_share"] == pytest.approx(1 - a.sum() / r.sum(), rel=0, abs=1e-12)
    assert total["relmse_part"] == pytest.approx(np.sum((r - a) ** 2) / np.sum(r**2), rel=1e-12)
    assert sum(_row(result, t)["energy_share"] for t in FIVE) == pytest.approx(total["energy_share"], abs=1e-12)
    assert sum(_row(result, t)["relmse_part"] for t in FIVE) == pytest.approx(total["relmse_part"], rel=1e-12)
    for t in FIVE:  # each term's own relMSE from its image
        own = np.sum(result["terms"][t][keep] ** 2) / np.sum(r**2)
        assert _row(result, t)["relmse_own"] == pytest.approx(own, rel=1e-12)
    assert result["options"]["pixels"] == int(keep.sum())
    assert result["options"]["small_batches"] == K


def test_constructed_ladder_has_known_shares():
    """R = 1 everywhere; E_∞,s's batches are exactly R (so every jackknife SE is 0);
    E_∞ = E_∞,s; E_∞(same) = 0.9 R; E_k = 0.8 R; A = 0.7 R. Each of intersection,
    truncation and reflections closes 0.1 of the energy; blur and residual are 0.
    relMSE parts: term · (R − A) / R² = 0.1 · 0.3 = 0.03; own: 0.1² = 0.01."""
    one = np.ones((H, W, 3))
    images = {"reference": one, "exact_all": one, "exact_all_same": 0.9 * one, "exact_steps": 0.8 * one,
              "approx": 0.7 * one}
    result = decompose_caustic(images, np.stack([one] * 8))
    expected = {"intersection": 0.1, "truncation": 0.1, "reflections": 0.1, "kernel_blur": 0.0, "residual": 0.0}
    for term, share in expected.items():
        row = _row(result, term)
        assert row["energy_share"] == pytest.approx(share, abs=1e-12), term
        assert row["relmse_part"] == pytest.approx(share * 0.3, abs=1e-12), term
        assert row["relmse_own"] == pytest.approx(share**2, abs=1e-12), term
        for field in ("energy_share_se", "relmse_part_se", "relmse_own_se"):
            assert row[field] == 0.0, (term, field)
        np.testing.assert_allclose(result["terms"][term], share * one, rtol=0, atol=1e-12)
    total = _row(result, "total")
    assert total["energy_share"] == pytest.approx(0.3, abs=1e-12)
    assert total["relmse_part"] == pytest.approx(0.09, abs=1e-12)
    noise = _row(result, "noise")  # no variances given: no noise
    assert noise["energy_share"] == 0.0 and noise["relmse_part"] == 0.0
    residual = result["residual"]
    assert residual["energy_share"] == 0.0 and residual["debiased_relmse"] == 0.0
    assert residual["within_noise"] and residual["message"] == ""


@pytest.mark.parametrize("k", [4, 5])
def test_identity_is_zero_and_within_noise(k):
    """Error of X with X: every term is 0, the total is 0 and the residual is within
    noise, whatever the number of (identical, noiseless) batches — their mean may
    differ from X in the last bit when K is not a power of 2."""
    rng = np.random.default_rng(11)
    x = rng.uniform(0.1, 2.0, (H, W, 3))
    images = {name: x for name in IMAGES if name != "exact_all_small"}
    result = decompose_caustic(images, np.stack([x] * k))
    for t in FIVE:
        np.testing.assert_allclose(result["terms"][t], 0.0, rtol=0, atol=1e-12)
        assert _row(result, t)["energy_share"] == pytest.approx(0.0, abs=1e-12)
        assert _row(result, t)["relmse_part"] == pytest.approx(0.0, abs=1e-12)
    total = _row(result, "total")
    assert total["energy_share"] == 0.0 and total["relmse_part"] == 0.0
    assert result["residual"]["within_noise"], result["residual"]


# --- the residual against noise ----------------------------------------------------


def test_a_wrong_reference_is_flagged():
    """R = 1.2 × the truth, E_∞,s = the truth with noise 0.01 per batch: a 20% energy
    gap against a standard error of ~1e-4 must not pass as noise."""
    rng = np.random.default_rng(12)
    truth = _truth()
    images = {"reference": 1.2 * truth, "exact_all": truth, "exact_all_same": truth, "exact_steps": truth,
              "approx": truth}
    batches = truth + 0.01 * rng.standard_normal((K, H, W, 3))
    residual = decompose_caustic(images, batches)["residual"]
    assert not residual["within_noise"]
    assert "disagree" in residual["message"]
    assert residual["energy_share"] == pytest.approx(1 - 1 / 1.2, abs=1e-3)
    assert residual["energy_z"] > 100 and residual["relmse_z"] > 100


@pytest.mark.parametrize("reference_noise", [False, True])
def test_an_unbiased_residual_is_within_noise(reference_noise):
    """E_∞,s's batches (K = 16, correlated over neighbours) and, in one variant, R
    too are noisy around one truth: the residual is pure noise. Each of its two
    z-scores exceeds the limit 3 for about 1% of draws or fewer (normal: 0.27%; the
    energy's jackknife SE from 16 batches makes its z a t with 15 degrees of freedom:
    0.9%; the jackknife of the quadratic debiased relMSE errs on the large side), so
    over 20 independent draws at most 2 false alarms is a generous bound
    (P(≥ 3 of 20) < 0.1% at a 2% rate per draw)."""
    truth = _truth()
    images = {"exact_all": truth, "exact_all_same": truth, "exact_steps": truth, "approx": truth}
    passed = 0
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        batches = truth + _blurred_noise(rng, (K, H, W, 3), 0.02)
        kwargs = {}
        if reference_noise:
            var = np.full_like(truth, 0.005**2)
            kwargs["reference_var"] = var
            images["reference"] = truth + np.sqrt(var) * rng.standard_normal(truth.shape)
        else:
            images["reference"] = truth
        residual = decompose_caustic(images, batches, **kwargs)["residual"]
        passed += residual["within_noise"]
        assert residual["within_noise"] == (residual["message"] == "")
    assert passed >= 18


# --- the compared pixels and bad input ---------------------------------------------


def test_pixels_outside_keep_change_nothing():
    rng = np.random.default_rng(13)
    images = _random_images(rng)
    batches = rng.uniform(0.1, 2.0, (K, H, W, 3))
    var = rng.uniform(0.0, 1e-3, (H, W, 3))
    keep = np.ones((H, W), bool)
    keep[:, :5] = False
    keep[3, 9] = False
    before = decompose_caustic(images, batches, keep=keep, reference_var=var, approx_var=var)
    garbage = {name: image.copy() for name, image in images.items()}
    for image in garbage.values():
        image[~keep] = rng.uniform(0.0, 100.0, (int((~keep).sum()), 3))
    noisy = batches.copy()
    noisy[:, ~keep] = rng.uniform(0.0, 100.0, (K, int((~keep).sum()), 3))
    var2 = var.copy()
    var2[~keep] = 5.0
    after = decompose_caustic(garbage, noisy, keep=keep, reference_var=var2, approx_var=var2)
    assert after["rows"] == before["rows"]
    assert after["residual"] == before["residual"]
    # and the garbage does matter when every pixel is compared
    assert decompose_caustic(garbage, noisy)["rows"] != decompose_caustic(images, batches)["rows"]


@pytest.mark.parametrize("bad", ["missing", "shape", "channels", "batches", "batch_shape", "keep_none",
                                 "keep_shape", "zero_reference", "not_finite"])
def test_bad_input_raises_value_error(bad):
    rng = np.random.default_rng(14)
    images = _random_images(rng)
    del images["exact_all_small"]  # the batches give it
    batches, kwargs = rng.uniform(0.1, 2.0, (K, H, W, 3)), {}
    if bad == "missing":
        del images["exact_steps"]
    elif bad == "shape":
        images["approx"] = images["approx"][:-1]
    elif bad == "channels":
        images["exact_all"] = images["exact_all"][..., :2]
    elif bad == "batches":
        batches = batches[:3]
    elif bad == "batch_shape":
        batches = batches[:, :-1]
    elif bad == "keep_none":
        kwargs["keep"] = np.zeros((H, W), bool)
    elif bad == "keep_shape":
        kwargs["keep"] = np.ones((H, W + 1), bool)
    elif bad == "zero_reference":
        images["reference"] = np.zeros((H, W, 3))
    else:
        images["approx"][2, 3, 1] = np.nan
    with pytest.raises(ValueError):
        decompose_caustic(images, batches, **kwargs)


def test_caustic_terms_names_the_missing_image():
    images = _random_images(np.random.default_rng(15))
    del images["exact_all_same"]
    with pytest.raises(ValueError, match="exact_all_same"):
        caustic_terms(images)


# --- standard errors ---------------------------------------------------------------


def test_jackknife_standard_error_matches_the_spread_over_draws():
    """The kernel blur's energy share and relMSE part are linear in E_∞,s, so their
    delete-one jackknife SE is the standard error of a mean over K batch images —
    which sees the noise shared by neighbouring pixels. Over 200 independent draws of
    the batches, the spread of the estimate must match the stated SE (root mean
    square over the draws). The sample standard deviation of 200 draws has a relative
    sampling error of 1/√(2·199) ≈ 5%, the RMS of the 200 stated SEs (each from K = 8
    batches) about 2%; 0.7–1.4 is over 6 of those standard errors either way, and
    leaves room for the jackknife's own small-sample bias."""
    rng = np.random.default_rng(16)
    truth = _truth()
    k = 8
    images = {"reference": 1.05 * truth, "exact_all": 0.97 * truth, "exact_all_same": 0.9 * truth,
              "exact_steps": 0.85 * truth, "approx": 0.8 * truth}
    energy = 1.05 * truth.sum() / 3  # Σ R averaged over RGB
    shares, parts, share_se, part_se, independent_se = [], [], [], [], []
    for _ in range(200):
        batches = truth + _blurred_noise(rng, (k, H, W, 3), 0.05)
        row = _row(decompose_caustic(images, batches), "kernel_blur")
        shares.append(row["energy_share"])
        parts.append(row["relmse_part"])
        share_se.append(row["energy_share_se"])
        part_se.append(row["relmse_part_se"])
        per_pixel_var = batches.var(axis=0, ddof=1).sum(axis=(0, 1)) / k  # RGB, pixels taken as independent
        independent_se.append(np.sqrt(per_pixel_var.sum() / 9) / energy)
    # the shared noise matters: pixels taken as independent would understate the SE ~3×
    assert np.mean(share_se) > 2 * np.mean(independent_se)
    assert 0.7 < np.std(shares, ddof=1) / np.sqrt(np.mean(np.square(share_se))) < 1.4
    assert 0.7 < np.std(parts, ddof=1) / np.sqrt(np.mean(np.square(part_se))) < 1.4
    # and the blur itself (E_∞,s − E_∞ = 0.03 truth) is found within its noise
    assert np.mean(shares) == pytest.approx(0.03 / 1.05, abs=4 * np.std(shares) / np.sqrt(200))
