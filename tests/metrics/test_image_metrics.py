"""Image metrics: identities, known errors, and scale invariance where the exposure is
chosen from the reference."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.metrics.image import (
    delta_e2000,
    delta_e2000_frames,
    energy_ratio,
    hdr_flip,
    per_pixel_relative_mse,
    reference_exposure,
    ssim,
)


def _image(seed=0, size=48):
    """A smooth HDR test image: a bright blob over a dim gradient, colours differing."""
    y, x = np.mgrid[0:size, 0:size] / size
    blob = np.exp(-((x - 0.4) ** 2 + (y - 0.5) ** 2) / 0.02)
    base = np.stack([0.05 + 0.1 * x, 0.04 + 0.05 * y, 0.03 + 0.02 * x * y], axis=2)
    return base + blob[..., None] * np.array([4.0, 2.5, 1.0])


@pytest.mark.parametrize("metric,perfect", [(per_pixel_relative_mse, 0.0), (ssim, 1.0), (delta_e2000, 0.0),
                                            (hdr_flip, 0.0)])
def test_identical_images_are_perfect(metric, perfect):
    r = _image()
    out = metric(r, r.copy())
    assert out["value"] == pytest.approx(perfect, abs=1e-9)
    assert out["pixels"] == r.shape[0] * r.shape[1]


def test_known_errors():
    r = _image()
    # energy ratio of a 10% brighter image, per channel
    assert energy_ratio(r, 1.1 * r)["value"] == pytest.approx([1.1] * 3)
    # per-pixel relMSE of t = 1.1 r: 0.01 · mean(r² / (r² + ε)), ε = 0.01 · mean(r²)
    out = per_pixel_relative_mse(r, 1.1 * r, epsilon=0.01)
    expected = 0.01 * np.mean(r * r / (r * r + 0.01 * np.mean(r * r)))
    assert out["value"] == pytest.approx(expected, rel=1e-9) and out["epsilon_absolute"] > 0


def test_worse_images_score_worse():
    r = _image()
    rng = np.random.default_rng(1)
    small = np.clip(r * (1 + 0.05 * rng.normal(size=r.shape)), 0, None)
    large = np.clip(r * (1 + 0.3 * rng.normal(size=r.shape)), 0, None)
    assert ssim(r, small)["value"] > ssim(r, large)["value"]
    assert delta_e2000(r, small)["value"] < delta_e2000(r, large)["value"]
    assert hdr_flip(r, small)["value"] < hdr_flip(r, large)["value"]
    assert per_pixel_relative_mse(r, small)["value"] < per_pixel_relative_mse(r, large)["value"]


def test_exposure_from_the_reference_makes_metrics_scale_free():
    """A caustic is dark in absolute terms (radiance ~1e-3): with exposures chosen from
    the reference, SSIM, ΔE2000 and HDR-FLIP do not change when both images are scaled
    (FLIP's own automatic range is not used for that reason)."""
    r = _image()
    t = np.clip(r * (1 + 0.1 * np.random.default_rng(2).normal(size=r.shape)), 0, None)
    for metric in (ssim, delta_e2000, hdr_flip):
        bright, dark = metric(r, t)["value"], metric(1e-4 * r, 1e-4 * t)["value"]
        assert dark == pytest.approx(bright, rel=1e-3, abs=1e-6), metric.__name__


def test_mask_selects_pixels_and_bad_input_raises():
    r = _image()
    t = r.copy()
    t[:, :10] *= 3.0  # error only in the left columns
    keep = np.ones(r.shape[:2], bool)
    keep[:, :10] = False
    assert per_pixel_relative_mse(r, t, mask=keep)["value"] == 0.0
    assert energy_ratio(r, t, mask=keep)["mean"] == pytest.approx(1.0)
    assert hdr_flip(r, t, mask=keep)["value"] < hdr_flip(r, t)["value"]
    with pytest.raises(ValueError, match="H×W×3"):
        ssim(r, r[:-1])
    with pytest.raises(ValueError, match="mask"):
        energy_ratio(r, r, mask=np.ones((3, 3), bool))
    with pytest.raises(ValueError, match="black"):
        hdr_flip(np.zeros_like(r), r)
    with pytest.raises(ValueError, match="finite"):
        delta_e2000(r, np.full_like(r, np.nan))


def test_delta_e2000_of_frames_at_once_equals_one_at_a_time():
    r = _image()
    rng = np.random.default_rng(3)
    tests = np.clip(r * (1 + 0.2 * rng.normal(size=(3,) + r.shape)), 0, None)
    keep = np.ones(r.shape[:2], bool)
    keep[:4] = False
    assert delta_e2000_frames(r, tests, mask=keep) == [delta_e2000(r, t, mask=keep) for t in tests]


def test_delta_e2000_is_colour_sciences():
    """scikit-image's CIEDE2000 over the images' linear sRGB → CIELAB is colour-science's
    (the oracle it replaced); a pipeline that decodes the already linear values as sRGB
    (colour-science's default) is flagged."""
    import colour

    r = _image()
    rng = np.random.default_rng(5)
    tests = np.clip(r * (1 + 0.3 * rng.normal(size=(3,) + r.shape)), 0, None)
    exposure = reference_exposure(r)
    space = colour.RGB_COLOURSPACES["sRGB"]

    def lab(x, decode):
        return colour.XYZ_to_Lab(colour.RGB_to_XYZ(np.clip(x * exposure, 0, 1), space, apply_cctf_decoding=decode))

    def oracle(decode):
        return [float(np.mean(colour.delta_E(lab(r, decode), lab(t, decode), method="CIE 2000"))) for t in tests]

    ours = [d["value"] for d in delta_e2000_frames(r, tests)]
    # the libraries' D65 whites and sRGB matrices differ in the 4th–5th digit: measured 5.7e-4 ΔE here at ΔE ≈ 8.2
    assert np.allclose(ours, oracle(False), rtol=0, atol=1e-3)
    assert not np.allclose(ours, oracle(True), rtol=0, atol=1e-1)
