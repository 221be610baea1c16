"""Image error metrics (pure numpy, float64 accumulation)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def _check(reference, test, mask):
    r = np.asarray(reference, dtype=np.float64)
    t = np.asarray(test, dtype=np.float64)
    if r.shape != t.shape:
        raise ValueError(f"shape mismatch: reference {r.shape}, test {t.shape}")
    if mask is None:
        return r, t
    m = np.asarray(mask, dtype=bool)
    if m.shape != r.shape[: m.ndim]:
        raise ValueError(f"mask shape {m.shape} does not match image shape {r.shape}")
    return r[m], t[m]


def relative_mse(reference: ArrayLike, test: ArrayLike, *, mask: ArrayLike | None = None) -> float:
    """Σ(test − reference)² / Σ reference²: the mean squared error relative to the
    reference's energy (0 for identical images).

    Parameters
    ----------
    reference, test : H×W×C arrays, linear radiance.
    mask : optional H×W (or H×W×C) boolean array of the pixels to compare.
    """
    r, t = _check(reference, test, mask)
    energy = float(np.sum(r * r))
    if energy == 0.0:
        raise ValueError("reference is zero everywhere: relative error undefined")
    return float(np.sum((t - r) ** 2) / energy)


def _keep(reference, mask) -> np.ndarray:
    """H×W bool of the pixels compared (``mask`` H×W or H×W×C, all pixels when None)."""
    if mask is None:
        return np.ones(reference.shape[:2], bool)
    m = np.asarray(mask, dtype=bool)
    if m.shape[:2] != reference.shape[:2]:
        raise ValueError(f"mask shape {m.shape} does not match image shape {reference.shape}")
    return m if m.ndim == 2 else np.asarray(m.all(axis=tuple(range(2, m.ndim))))


def _images(reference, test):
    r = np.asarray(reference, dtype=np.float64)
    t = np.asarray(test, dtype=np.float64)
    if r.shape != t.shape or r.ndim != 3 or r.shape[2] != 3:
        raise ValueError(f"expected two H×W×3 images of one shape, got reference {r.shape}, test {t.shape}")
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(t))):
        raise ValueError("images must be finite")
    return r, t


def _frames(reference, tests):
    """:func:`_images` for S tests against one reference: (H×W×3, S×H×W×3) float64."""
    t = np.asarray(tests, dtype=np.float64)
    if t.ndim != 4 or len(t) == 0:
        raise ValueError(f"tests: shape {t.shape}, expected S×H×W×3 with S ≥ 1")
    r, _ = _images(reference, t[0])
    if t.shape[1:] != r.shape or not np.all(np.isfinite(t)):
        raise ValueError(f"expected finite H×W×3 images of one shape, got reference {r.shape}, tests {t.shape}")
    return r, t


def per_pixel_relative_mse(reference: ArrayLike, test: ArrayLike, *, mask: ArrayLike | None = None,
                           epsilon: float = 1e-2, full: bool = False) -> dict:
    """Mean over pixels of (test − reference)² / (reference² + ε), ε = ``epsilon`` times
    the mean of reference² over the compared pixels (so the floor scales with the image):
    large errors in dark pixels count without dividing by zero.

    Parameters
    ----------
    reference, test : H×W×3 arrays, linear radiance.
    mask : optional H×W boolean array of the pixels to compare.
    epsilon : the floor, relative to the mean of reference².
    full : also return the error map (as scikit-image's ``full=True``).

    Returns
    -------
    dict: ``value`` and the options used (``epsilon``, ``epsilon_absolute``, ``pixels``);
    with ``full``, ``map``: H×W float64, each pixel's error averaged over its channels
    (its mean over the compared pixels is ``value``), NaN where not compared.
    """
    r, t = _images(reference, test)
    keep = _keep(r, mask)
    floor = epsilon * float(np.mean(r[keep] ** 2))
    if not floor > 0:
        raise ValueError("reference is zero everywhere: relative error undefined")
    per_pixel = np.mean((t - r) ** 2 / (r * r + floor), axis=2)
    out: dict[str, object] = {"value": float(per_pixel[keep].mean()), "epsilon": epsilon, "epsilon_absolute": floor,
           "pixels": int(keep.sum())}
    if full:
        out["map"] = np.where(keep, per_pixel, np.nan)
    return out


def reference_exposure(reference: ArrayLike, *, mask: ArrayLike | None = None, percentile: float = 99.5) -> float:
    """Exposure that maps the reference's bright pixels (``percentile`` of the nonzero
    luminance over the compared pixels) to 1: one exposure for both images."""
    return float(1.0 / np.percentile(_lit_luminance(reference, mask), percentile))


def _lit_luminance(reference, mask) -> np.ndarray:
    """Rec.709 luminance of the compared pixels that are not black; ValueError if none."""
    r = np.asarray(reference, dtype=np.float64)
    lum = (r @ np.array([0.2126, 0.7152, 0.0722]))[_keep(r, mask)]
    lum = lum[lum > 0]
    if lum.size == 0:
        raise ValueError("reference is black: no exposure to choose")
    return lum


def _display(rgb, exposure):
    """Linear radiance × exposure, clipped to [0, 1], sRGB-encoded (infra.imageio's OETF)."""
    from volcaustics.infra.imageio import srgb_encode

    return srgb_encode(np.clip(rgb * exposure, 0.0, 1.0))


SSIM_SIGMA = 1.5  # Wang et al. 2004's Gaussian weights
# scikit-image's Gaussian window: 2·int(3.5·σ + 0.5) + 1 pixels; a smaller image is refused
SSIM_WINDOW = 2 * int(3.5 * SSIM_SIGMA + 0.5) + 1


def ssim(reference: ArrayLike, test: ArrayLike, *, mask: ArrayLike | None = None,
         exposure: float | None = None) -> dict:
    """SSIM (scikit-image, Gaussian weights as Wang et al. 2004) of the two images shown
    with one exposure (the reference's, :func:`reference_exposure`, unless given),
    clipped and sRGB-encoded, averaged over the compared pixels; 1 for identical images."""
    from skimage.metrics import structural_similarity

    r, t = _images(reference, test)
    keep = _keep(r, mask)
    exposure = exposure if exposure is not None else reference_exposure(r, mask=mask)
    _, full = structural_similarity(_display(r, exposure), _display(t, exposure), channel_axis=2, data_range=1.0,
                                    gaussian_weights=True, sigma=SSIM_SIGMA, use_sample_covariance=False, full=True)
    return {"value": float(full.mean(axis=2)[keep].mean()), "exposure": exposure, "gaussian_weights": True,
            "sigma": SSIM_SIGMA, "pixels": int(keep.sum())}


def delta_e2000(reference: ArrayLike, test: ArrayLike, *, mask: ArrayLike | None = None,
                exposure: float | None = None) -> dict:
    """Mean and 99th percentile CIEDE2000 colour difference (Sharma, Wu & Dalal 2005, as
    scikit-image's ``deltaE_ciede2000``) of the two images shown with one exposure (the
    reference's unless given), via linear sRGB → XYZ → CIELAB (D65, 2°), over the compared
    pixels; 0 for identical images."""
    t = np.asarray(test)
    if t.ndim != 3:
        raise ValueError(f"expected two H×W×3 images of one shape, got reference {np.shape(reference)}, "
                         f"test {t.shape}")
    return delta_e2000_frames(reference, t[None], mask=mask, exposure=exposure)[0]


def delta_e2000_frames(reference: ArrayLike, tests: ArrayLike, *, mask: ArrayLike | None = None,
                       exposure: float | None = None) -> list:
    """:func:`delta_e2000` of each of ``tests`` (S×H×W×3, linear radiance) against one
    ``reference`` (H×W×3): the reference's CIELAB once, every test's pixels in one call
    (the difference is per pixel, so each value is the one-pair call's). scikit-image, not
    colour-science, whose import alone costs 1.3–3 s a process; the two agree within
    1e-3 ΔE (docs/decisions.md "ΔE2000 without colour-science")."""
    from skimage.color import deltaE_ciede2000, xyz2lab
    from skimage.color.colorconv import xyz_from_rgb

    r, t = _frames(reference, tests)
    keep = _keep(r, mask)
    exposure = exposure if exposure is not None else reference_exposure(r, mask=mask)

    def lab(rgb):
        shown = np.clip(rgb * exposure, 0.0, 1.0)  # linear, as displayed
        return xyz2lab(shown @ xyz_from_rgb.T, illuminant="D65", observer="2")

    n = int(keep.sum())
    de = deltaE_ciede2000(np.tile(lab(r[keep]), (len(t), 1)), lab(t[:, keep].reshape(-1, 3)),
                          channel_axis=-1).reshape(len(t), n)
    return [{"value": float(np.mean(x)), "p99": float(np.percentile(x, 99)), "exposure": exposure, "pixels": n}
            for x in de]


def hdr_flip(reference: ArrayLike, test: ArrayLike, *, mask: ArrayLike | None = None,
             start_exposure: float | None = None,
             stop_exposure: float | None = None, ppd: float = 67.0, full: bool = False) -> dict:
    """HDR-FLIP (Andersson et al. 2021, as NVIDIA's ``flip-evaluator``: ``metrics.flip``)
    over the compared pixels; 0 for identical images.

    FLIP's automatic exposure range fails on dark images, so it is chosen from the
    reference: from the exposure that maps its bright pixels (99.5th percentile of the
    nonzero luminance) to 1 up to the one that maps its median nonzero pixel to 1.
    With ``full``, ``map`` is FLIP's error map (H×W float64 in [0, 1], NaN where not
    compared; its mean over the compared pixels is ``value``).
    """
    t = np.asarray(test)
    if t.ndim != 3:
        raise ValueError(f"expected two H×W×3 images of one shape, got reference {np.shape(reference)}, "
                         f"test {t.shape}")
    return hdr_flip_frames(reference, t[None], mask=mask, start_exposure=start_exposure, stop_exposure=stop_exposure,
                           ppd=ppd, full=full)[0]


def hdr_flip_frames(reference: ArrayLike, tests: ArrayLike, *, mask: ArrayLike | None = None,
                    start_exposure: float | None = None,
                    stop_exposure: float | None = None, ppd: float = 67.0, full: bool = False) -> list:
    """:func:`hdr_flip` of each of ``tests`` (S×H×W×3, linear radiance) against one
    ``reference`` (H×W×3), in one pass (``metrics.flip.hdr_flip_maps``): a list of S
    dicts, each as :func:`hdr_flip`'s."""
    from volcaustics.metrics.flip import exposures, hdr_flip_maps

    r, t = _frames(reference, tests)
    keep = _keep(r, mask)
    lum = _lit_luminance(r, mask)
    start = float(np.log2(1.0 / np.percentile(lum, 99.5))) if start_exposure is None else float(start_exposure)
    stop = float(np.log2(1.0 / np.median(lum))) if stop_exposure is None else float(stop_exposure)
    stop = max(stop, start)
    if not ppd > 0:
        raise ValueError(f"ppd = {ppd!r}: expected pixels per degree > 0")
    maps = hdr_flip_maps(r, t, start_exposure=start, stop_exposure=stop, ppd=float(ppd))
    out = []
    for error_map in maps:
        error = np.asarray(error_map, np.float64)
        value: dict[str, object] = {"value": float(error[keep].mean()), "start_exposure": start,
                                    "stop_exposure": stop,
                 "num_exposures": len(exposures(start, stop)), "ppd": float(ppd), "pixels": int(keep.sum())}
        if full:
            value["map"] = np.where(keep, error, np.nan)
        out.append(value)
    return out


def energy_ratio(reference: ArrayLike, test: ArrayLike, *, mask: ArrayLike | None = None) -> dict:
    """Σ test / Σ reference per colour channel over the compared pixels (1 = same energy)."""
    r, t = _images(reference, test)
    keep = _keep(r, mask)
    total = r[keep].sum(axis=0)
    if not np.all(total > 0):
        raise ValueError("reference has no energy in some channel: ratio undefined")
    ratio = t[keep].sum(axis=0) / total
    return {"value": ratio.tolist(), "mean": float(ratio.mean()), "pixels": int(keep.sum())}
