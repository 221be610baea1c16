"""The caustic's error split into its causes (pure numpy, float64 accumulation).

DESIGN.md, "Measuring the error" → Images. With one splatter for all images:

=====================  =======================================================
``approx``             A: the approximation's caustic (mean over its seeds)
``exact_steps``        E_k: its photons replayed exactly, same ``fresnel`` and ``steps``
``exact_all_same``     E_∞ with A's ``fresnel``: so many steps that < 0.1% of the
                       power is still alive
``exact_all``          E_∞: the same with stochastic Fresnel (every reflection kept)
``exact_all_small``    E_∞,s: E_∞ splatted with a small kernel, box-filtered pixels
``reference``          R: the reference light tracer
=====================  =======================================================

The terms telescope, so they sum to R − A exactly, pixel by pixel:

==================  ===================  ===========================================
``intersection``    E_k − A              the image-space intersection estimate
``truncation``      E_∞(same) − E_k      paths cut after ``steps`` interactions
``reflections``     E_∞ − E_∞(same)      reflections a deterministic Fresnel drops
                                         (zero when A is stochastic)
``kernel_blur``     E_∞,s − E_∞          the splat kernel's blur (and point-sampled
                                         pixels)
``residual``        R − E_∞,s            what none of the above explains: must be
                                         within noise, else a renderer is wrong
==================  ===================  ===========================================

Each term is the change that removing its cause brings towards R; DESIGN.md writes
the blur as E_∞ − E_∞,s, the opposite sign, which would not sum to R − A.

Each term is given, over the compared pixels and averaged over RGB, as an *energy
share* Σ term / Σ R (they sum to 1 − Σ A / Σ R) and as its *part of the relative
MSE* Σ term · (R − A) / Σ R² (they sum to the relative MSE Σ (R − A)² / Σ R²: the
projection of each term on the total error; a negative part is a term that
cancels some of another's error), and with its own relative MSE Σ term² / Σ R².
*Noise* is not a term but a statement of how much of the total it may explain: the
reference's floor plus the approximation's own variance over seeds (relative MSE)
and the standard deviation of the energy difference (energy share).
"""

from __future__ import annotations

import numpy as np

IMAGES = ("approx", "exact_steps", "exact_all_same", "exact_all", "exact_all_small", "reference")
TERMS = {  # name: (closer to R, farther from R)
    "intersection": ("exact_steps", "approx"),
    "truncation": ("exact_all_same", "exact_steps"),
    "reflections": ("exact_all", "exact_all_same"),
    "kernel_blur": ("exact_all_small", "exact_all"),
    "residual": ("reference", "exact_all_small"),
}
CHANNEL_WEIGHTS = np.full(3, 1.0 / 3.0)  # energy shares average R, G and B


def _image(images, name, shape=None):
    if name not in images:
        raise ValueError(f"images: missing {name!r} (expected {', '.join(IMAGES)})")
    a = np.asarray(images[name], dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"images[{name!r}]: shape {a.shape}, expected H×W×3")
    if shape is not None and a.shape != shape:
        raise ValueError(f"images[{name!r}]: shape {a.shape}, expected {shape} like 'reference'")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"images[{name!r}]: not finite everywhere")
    return a


def caustic_terms(images: dict) -> dict:
    """The five terms as H×W×3 float64 images (they sum to reference − approx)."""
    shape = _image(images, "reference").shape
    full = {name: _image(images, name, shape) for name in IMAGES}
    return {term: full[near] - full[far] for term, (near, far) in TERMS.items()}


def _total_sigma(var_total, var_pixels, keep) -> float:
    """σ of the RGB-averaged sum over the kept pixels: from ``var_total`` (RGB, the
    variances of the sums, covariance of pixels included) when given, else from the
    sums of the per-pixel variances (pixels taken as independent). The channels of
    one photon are strongly correlated, so their σ add (an upper bound) rather than
    their variances."""
    if var_total is None:
        if var_pixels is None:
            return 0.0
        var_total = np.asarray(var_pixels, np.float64)[keep].sum(axis=0)
    return float(np.sqrt(np.maximum(np.asarray(var_total, np.float64), 0.0)) @ CHANNEL_WEIGHTS)


def decompose_caustic(images: dict, small_batches, *, keep=None, reference_var=None, reference_total_var=None,
                      approx_var=None, approx_total_var=None, z_limit: float = 3.0) -> dict:
    """Split the caustic's error R − A into the terms of this module.

    Parameters
    ----------
    images : dict of H×W×3 linear radiance images named as ``IMAGES``, except
        ``exact_all_small``, which is the mean of ``small_batches``.
    small_batches : K×H×W×3, K ≥ 4 independent estimates of E_∞,s (photon subsets):
        its mean, its noise, and delete-one jackknife standard errors of every
        number that involves it (its splats spread over neighbouring pixels, so
        pixels are not independent; the jackknife over whole images sees that).
    keep : H×W bool, the pixels compared (default all): not glass in either renderer.
    reference_var, approx_var : H×W×3 variances of the means R and A per pixel (None:
        unknown, taken as 0; A's needs ≥ 2 seeds).
    reference_total_var, approx_total_var : RGB variances of the sums over ``keep``
        (covariance of pixels included); when None, the sums of per-pixel variances.
    z_limit : the residual is within noise when both its energy and its debiased
        relative MSE are within ``z_limit`` standard errors of 0.

    Returns
    -------
    dict with
      ``terms``: name → H×W×3 image (the five terms);
      ``images``: the six images (``exact_all_small`` the batches' mean);
      ``rows``: one dict per term — ``term``, ``energy_share``, ``relmse_part``,
        ``relmse_own`` and their standard errors ``*_se`` (0 where E_∞,s is not
        involved: those terms' noise is A's and the replay's, shared photons) —
        then ``total`` (R − A: 1 − energy ratio, the relative MSE) and ``noise``
        (``energy_share``: σ of Σ(R − A) / Σ R; ``relmse_part``: the relative MSE
        noise alone gives, reference floor + A's variance);
      ``residual``: ``energy_share``, ``energy_z``, ``debiased_relmse`` (Σ(R − E_∞,s)²
        less both noises, over Σ R²), ``relmse_z``, ``within_noise`` and a
        ``message`` saying which renderers disagree when it is not;
      ``options``: what was used.
    """
    batches = np.asarray(small_batches, np.float64)
    if batches.ndim != 4 or len(batches) < 4:
        raise ValueError(f"small_batches: shape {batches.shape}, expected K×H×W×3 with K ≥ 4")
    images = {**images, "exact_all_small": batches.mean(axis=0)}
    reference = _image(images, "reference")
    keep = np.ones(reference.shape[:2], bool) if keep is None else np.asarray(keep, bool)
    if keep.shape != reference.shape[:2]:
        raise ValueError(f"keep: shape {keep.shape}, expected {reference.shape[:2]}")
    if not keep.any():
        raise ValueError("keep selects no pixel")
    terms = caustic_terms(images)
    r = reference[keep]
    energy = float(r.sum(axis=0) @ CHANNEL_WEIGHTS)
    energy2 = float(np.sum(r * r))
    if not (energy > 0 and energy2 > 0):
        raise ValueError("reference caustic is zero over the compared pixels: shares are undefined")
    d = (reference - _image(images, "approx"))[keep]
    rv = np.zeros_like(r) if reference_var is None else np.asarray(reference_var, np.float64)[keep]
    kept = {name: images[name][keep] for name in IMAGES}

    def numbers(small):
        """Energy share, relMSE part and own relMSE of every term, and the residual's
        debiased relMSE, for one estimate of E_∞,s (N×3 kept pixels)."""
        full = {**kept, "exact_all_small": small}
        out = {}
        for name, (near, far) in TERMS.items():
            t = full[near] - full[far]
            out[name] = (float(t.sum(axis=0) @ CHANNEL_WEIGHTS) / energy, float(np.sum(t * d)) / energy2,
                         float(np.sum(t * t)) / energy2)
        return out

    small_kept = batches[:, keep]
    k = len(batches)
    value = numbers(small_kept.mean(axis=0))
    small_var = small_kept.var(axis=0, ddof=1) / k
    residual_sq = float(np.sum((r - small_kept.mean(axis=0)) ** 2))
    debiased = (residual_sq - float(rv.sum()) - float(small_var.sum())) / energy2
    # delete-one jackknife over E_∞,s's batches
    leave_out = []
    for i in range(k):
        rest = np.delete(small_kept, i, axis=0)
        nums = numbers(rest.mean(axis=0))
        rest_var = rest.var(axis=0, ddof=1) / (k - 1)
        nums["debiased"] = ((float(np.sum((r - rest.mean(axis=0)) ** 2)) - float(rv.sum()) - float(rest_var.sum()))
                            / energy2,)
        leave_out.append(nums)

    def se(name, i):
        v = np.array([x[name][i] for x in leave_out])
        return float(np.sqrt((k - 1) / k * np.sum((v - v.mean()) ** 2)))

    rows = []
    for name in TERMS:
        row = {"term": name}
        for i, field in enumerate(("energy_share", "relmse_part", "relmse_own")):
            row[field] = value[name][i]
            row[f"{field}_se"] = se(name, i)
        rows.append(row)
    rows.append({"term": "total", "energy_share": float(d.sum(axis=0) @ CHANNEL_WEIGHTS) / energy,
                 "relmse_part": float(np.sum(d * d)) / energy2, "relmse_own": float(np.sum(d * d)) / energy2})

    def var_sum(v):
        return 0.0 if v is None else float(np.asarray(v, np.float64)[keep].sum())

    noise_sigma = np.hypot(_total_sigma(reference_total_var, reference_var, keep),
                           _total_sigma(approx_total_var, approx_var, keep))
    noise_relmse = (var_sum(reference_var) + var_sum(approx_var)) / energy2
    rows.append({"term": "noise", "energy_share": float(noise_sigma) / energy, "relmse_part": noise_relmse,
                 "relmse_own": noise_relmse})

    # the residual: R's noise adds to the jackknife's (E_∞,s only) in quadrature
    ref_sigma = _total_sigma(reference_total_var, reference_var, keep) / energy
    energy_se = float(np.hypot(se("residual", 0), ref_sigma))
    relmse_se = float(np.hypot(se("debiased", 0), np.sqrt(2.0 * np.sum(rv * rv)) / energy2))
    residual = {"energy_share": value["residual"][0], "energy_se": energy_se,
                "energy_z": _z(value["residual"][0], energy_se), "debiased_relmse": debiased,
                "relmse_se": relmse_se, "relmse_z": _z(debiased, relmse_se)}
    residual["within_noise"] = bool(abs(residual["energy_z"]) <= z_limit and residual["relmse_z"] <= z_limit)
    residual["message"] = "" if residual["within_noise"] else (
        f"the reference and the exact photons through the approximation's splatter disagree beyond their noise "
        f"(residual energy {100 * residual['energy_share']:+.2f}% of the reference, z = {residual['energy_z']:+.1f}; "
        f"debiased relative MSE {debiased:.2e}, z = {residual['relmse_z']:+.1f}; limit {z_limit:g}): one of them is "
        f"wrong — the reference light tracer, or the exact tracer and the splatter (tests/cross/test_v6.py checks "
        f"them against each other), and the terms do not explain the whole error")
    options = {"z_limit": z_limit, "pixels": int(keep.sum()), "small_batches": k,
               "approx_variance_known": approx_var is not None, "blur_sign": "exact_all_small - exact_all",
               "standard_errors": "delete-one jackknife over small_batches; reference noise in quadrature"}
    return {"terms": terms, "images": images, "rows": rows, "residual": residual, "options": options}


ROUNDING = 1e-12  # relative values (shares of the reference) this small are float64 rounding, not a difference


def _z(value: float, se: float) -> float:
    """value / se; with no noise at all (se 0), ±inf unless value is rounding."""
    if se > 0:
        return value / se
    return 0.0 if abs(value) <= ROUNDING else float(np.copysign(np.inf, value))
