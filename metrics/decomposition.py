"""The caustic's error split into its causes (pure numpy, float64 accumulation).

docs/concepts/measuring.md → Images. With one splatter for all:

=======================  =====================================================
``approx``               A: the approximation's caustic (mean over its seeds)
``approx_exact_march``   A_m: A with every fixed march of ρ exact (heterogeneous
                         media: the light's path, a segment's, along a beam;
                         control ``EXACT_MARCH``); A itself in a homogeneous medium
``exact_steps``          E_k: A's emission rays replayed exactly from the light, same
                         ``fresnel`` and ``steps``
``exact_all_same``       E_∞ with A's ``fresnel``: so many steps that < 0.1% of the
                         power is still alive
``exact_all``            E_∞: the same with stochastic Fresnel (every reflection kept)
``exact_emission``       E_em: E_∞ of photons from the light's true distribution
                         (jittered in every texel, the spot's exact profile)
``exact_all_small``      E_∞,s: E_em splatted with a small kernel, box-filtered pixels
``exact_all_small_eye``  E_∞,s,τ: E_∞,s with the transmittance to the eye exact instead
                         of the camera volume's (control ``EXACT_EYE``); E_∞,s itself
                         in a homogeneous medium
``reference``            R: the reference light tracer
=======================  =====================================================

Every E image is splatted with the march exact, as A_m is.

The terms telescope, so they sum to R − A exactly, pixel by pixel (in the order a
reader meets them, the emission first; the chain runs A → A_m → E_k → E_∞ → E_em → E_∞,s → E_∞,s,τ
→ R):

==================  ===================  ===========================================
``emission``        E_em − E_∞           where A's photons leave the light: the
                                         emission grid's aliasing, or any emission
                                         rule's bias
``march``           A_m − A              a heterogeneous medium's transmittance
                                         marched with ``march_steps`` samples of ρ
                                         (zero in a homogeneous one)
``intersection``    E_k − A_m            the image-space intersection estimate (the
                                         emission map's first interaction included)
``truncation``      E_∞(same) − E_k      paths cut after ``steps`` interactions
``reflections``     E_∞ − E_∞(same)      reflections a deterministic Fresnel drops
                                         (zero when A is stochastic)
``kernel_blur``     E_∞,s − E_em         the splat kernel's blur (and point-sampled
                                         pixels)
``camera_volume``   E_∞,s,τ − E_∞,s      a heterogeneous medium's transmittance to
                                         the eye from the camera volume (zero in a
                                         homogeneous one)
``residual``        R − E_∞,s,τ          what none of the above explains: must be
                                         within noise, else a renderer is wrong
==================  ===================  ===========================================

Each term is the change that removing its cause brings towards R (so the blur is
E_∞,s − E_em, not E_em − E_∞,s: the terms sum to R − A).

Each term is given, over the compared pixels, as an *energy share* Σ term / Σ R per
channel, averaged over RGB (they sum to 1 − the energy ratio, ``metrics.image.
energy_ratio``'s mean), as its *part of the relative MSE* Σ term · (R − A) / Σ R²
(they sum to the relative MSE Σ (R − A)² / Σ R²: the projection of each term on the
total error; a negative part is a term that cancels some of another's error), and
with its own relative MSE Σ term² / Σ R².

Debiased parts. Σ term · (R − A) also holds the noise the term shares with R − A: the
exact images replay A's photons, so their noise is correlated with A's, the more so the
closer their kernels (adaptive splats, whose kernels are narrow where photons are dense,
put ~3 points of sphere1's relative MSE into the residual's part that way). Each row's
``relmse_part_debiased`` subtracts that covariance, estimated over the paired batches
(and R's variance from the residual and the total): the debiased parts sum to the total's,
Σ(R − A)² less A's variance of the mean and R's floor — the debiased relative MSE. Their
standard errors are taken as the raw parts' (the correction is a constant of the batches).

Noise. Every image but R comes as K *paired* batch images: batch k of each is the
caustic of the same emission texels (photon subset k of one seed, times K), so the
terms, which difference images of the same photons, keep their small noise. A
delete-one jackknife over the paired batches gives the standard error of every
number (it sees the correlation of neighbouring pixels that one splat shares); R's
own noise (its energy's σ: its per-pixel variances and the measured ratio by which its
pixels covary, ``metrics.noise.total_sigma``) is added in quadrature where R enters (the
total and the residual). For the residual's debiased
relative MSE, a degenerate U-statistic when the residual is pure noise, the delete-one
jackknife overstates the noise×noise part of the variance by 2(K−1)/(K−2) (the
Efron–Stein bias): its SE is then up to 1.5× too large at K = 8 (docs/decisions.md
"Jackknife calibration"), so the test is conservative. *Noise* is not a term but
how much of the total noise alone explains: the relative MSE of the reference's floor
plus A's variance, and the standard deviation of the energy difference.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from volcaustics.metrics.groups import checked_groups, group_jackknife_se
from volcaustics.metrics.noise import total_sigma

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

IMAGES = ("approx", "approx_exact_march", "exact_steps", "exact_all_same", "exact_all", "exact_emission",
          "exact_all_small", "exact_all_small_eye", "reference")
BATCHED = IMAGES[:-1]  # every image but the reference comes as paired batches
TERMS = {  # name: (closer to R, farther from R)
    "emission": ("exact_emission", "exact_all"),
    "march": ("approx_exact_march", "approx"),
    "intersection": ("exact_steps", "approx_exact_march"),
    "truncation": ("exact_all_same", "exact_steps"),
    "reflections": ("exact_all", "exact_all_same"),
    "kernel_blur": ("exact_all_small", "exact_emission"),
    "camera_volume": ("exact_all_small_eye", "exact_all_small"),
    "residual": ("reference", "exact_all_small_eye"),
}
LAST = TERMS["residual"][1]  # the image the residual compares R with
ROUNDING = 1e-12  # relative values (shares of the reference) this small are float64 rounding, not a difference


def _z(value: float, se: float) -> float:
    """value / se; 0 for a value at rounding level (whatever the SE, itself rounding
    then), ±inf for a real difference without noise."""
    if abs(value) <= ROUNDING:
        return 0.0
    if se > 0:
        return value / se
    return float(np.copysign(np.inf, value))


def _stack(batches, name, shape=None):
    if name not in batches:
        raise ValueError(f"batches: missing {name!r} (expected {', '.join(BATCHED)})")
    a = np.asarray(batches[name])
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    if a.ndim != 4 or a.shape[3] != 3:
        raise ValueError(f"batches[{name!r}]: shape {a.shape}, expected K×H×W×3")
    if shape is not None and a.shape != shape:
        raise ValueError(f"batches[{name!r}]: shape {a.shape}, expected {shape} like {BATCHED[0]!r} (paired batches)")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"batches[{name!r}]: not finite everywhere")
    return a


def _reference_relmse_se(groups, keep, rv, sums, k, energy2) -> float:
    """R's part of the SE of the residual's debiased relMSE, E held at its mean: with
    ``groups`` a delete-one-group jackknife (:func:`_grouped_se`), else √(2 Σ var²)
    (pixels independent: noise × noise only)."""
    if groups is None:
        return float(np.sqrt(2.0 * np.sum(rv * rv))) / energy2
    e = sums[LAST] / k
    return _grouped_se(groups, keep, e, e, float(rv.sum())) / energy2


def _reference_part_se(term: str, groups, keep, r, rv, sums, k, energy2) -> float:
    """R's part of the SE of the relMSE part of ``term`` ("total": Σ(R − A)², "residual":
    Σ(R − E_∞,s,τ)(R − A), each less R's noise), the batched images held at their means:
    with ``groups`` a delete-one-group jackknife (R's pixels covary), else first order
    with independent pixels (Σ var · (∂/∂R)², plus 2 Σ var² for the noise × noise part)."""
    a = sums["approx"] / k
    e = a if term == "total" else sums[LAST] / k
    if groups is None:
        return float(np.sqrt(np.sum(rv * ((r - e) + (r - a)) ** 2) + 2.0 * np.sum(rv * rv))) / energy2
    return _grouped_se(groups, keep, e, a, float(rv.sum())) / energy2


def _grouped_se(groups, keep, e, a, noise: float) -> float:
    """The delete-one-group jackknife SE (``metrics.groups``) of Σ(R − e)(R − a) less R's
    noise (``noise``, scaled to the batches left), R without one of its ``groups``."""
    means, counts = checked_groups(groups)

    def product(images, scales):
        return float(np.sum((images[0] - e) * (images[0] - a))) - noise * scales[0]

    return cast(float, group_jackknife_se([(means[:, keep], counts)], product))  # one statistic: one SE


def caustic_terms(images: dict) -> dict:
    """The terms as H×W×3 float64 images of the ``IMAGES`` (they sum to reference −
    approx)."""
    for name in IMAGES:
        if name not in images:
            raise ValueError(f"images: missing {name!r} (expected {', '.join(IMAGES)})")
    full = {name: np.asarray(images[name], np.float64) for name in IMAGES}
    return {term: full[near] - full[far] for term, (near, far) in TERMS.items()}


def decompose_caustic(batches: dict, reference: ArrayLike, *, keep: ArrayLike | None = None,
                      reference_var: ArrayLike | None = None,
                      reference_ratio: Sequence[float] | np.ndarray | None = None,
                      reference_groups: tuple[ArrayLike, ArrayLike] | None = None, z_limit: float = 3.0,
                      subsets: int | None = None) -> dict:
    """Split the caustic's error R − A into the terms of this module.

    Parameters
    ----------
    batches : name → K×H×W×3 paired batch images (K ≥ 4) for every name of ``BATCHED``
        (all images but the reference): batch k of each is the caustic of the same
        photons (emission texels of one subset and seed) times K, so that the mean
        over k is the image.
    reference : H×W×3, R (linear radiance).
    keep : H×W bool, the pixels compared (default all): not glass in either renderer.
    reference_var : H×W×3 variance of R per pixel (None: taken as 0).
    reference_ratio : per channel, the variance of R's total over Σ of its pixels'
        (``metrics.noise.total_sigma``; None: 1, pixels independent).
    reference_groups : (G×H×W×3 means of G ≥ 4 independent groups of R's batches, their
        G batch counts), for R's part of the residual relMSE's SE (a delete-one-group
        jackknife, which sees R's pixels covary); None: pixels independent.
    z_limit : the residual is within noise when its energy and its debiased relative
        MSE are within ``z_limit`` standard errors of 0.
    subsets : the batches are seeds × ``subsets`` photon subsets, seed-major (batch j:
        subset j mod ``subsets`` of seed j // ``subsets``): with two seeds or more the noise
        is estimated within each subset, across the seeds (module docstring, "Strata").
        None: every batch an independent unit.

    Returns
    -------
    dict with
      ``images``: the images (means of the batches, and R);
      ``terms``: name → H×W×3 image (the terms);
      ``rows``: one dict per term and for ``total`` (R − A) — ``term``,
        ``energy_share``, ``relmse_part``, ``relmse_own`` and their standard errors
        ``*_se``, and ``relmse_part_debiased`` — then ``noise``: ``energy_sigma`` (σ of the total's energy share)
        and ``relmse`` (the relative MSE noise alone gives: R's floor + A's variance);
      ``residual``: ``energy_share`` and ``energy_se``, ``energy_z``,
        ``debiased_relmse`` (Σ(R − E_∞,s,τ)² less both noises, over Σ R²) and
        ``relmse_se``, ``relmse_z``, ``within_noise`` and a ``message`` saying which
        renderers disagree when it is not;
      ``options``: what was used.
    """
    stacks, r_full, keep, rv = cast("tuple[dict, np.ndarray, np.ndarray, np.ndarray]",
                                    _checked(batches, reference, keep, reference_var))
    k = len(stacks[BATCHED[0]])
    strata = _Strata(k, subsets)
    r = r_full[keep]
    channel_energy = r.sum(axis=0)
    energy2 = float(np.sum(r * r))
    if not (np.all(channel_energy > 0) and energy2 > 0):
        raise ValueError("reference caustic is zero over the compared pixels (in some channel): shares are undefined")
    # Σ over the batches of every pixel (H×W×3), summed in batch order as a sum of the kept pixels
    # alone would be: the kept pixels' sums and the images' means both come from it
    full_sums = _once(stacks, lambda s: s.sum(axis=0, dtype=np.float64))
    kept = _once(stacks, lambda s: strata.centred(s[:, keep]))  # K×N×3, as given (float32 or float64)
    jack = _Jackknife(kept, _once(full_sums, lambda s: s[keep]), r, channel_energy, energy2,
                      float(rv.sum()), strata.factor)
    value = jack.numbers(jack.means_without(None))
    leave_out = [jack.numbers(jack.means_without(i)) for i in range(k)]
    rows = _rows(jack, value, leave_out, rv, reference_ratio, reference_groups, keep)
    relmse_se = float(np.hypot(_jackknife_se(leave_out, "debiased") * np.sqrt(strata.factor),
                               _reference_relmse_se(reference_groups, keep, rv, jack.sums, k, energy2)))
    residual = _residual(next(x for x in rows if x["term"] == "residual"), value["debiased"], relmse_se, z_limit)
    images = {name: full_sums[name] / k for name in BATCHED}  # the batches' means (np.mean's own sum / k)
    images["reference"] = r_full
    options = {"z_limit": z_limit, "pixels": int(keep.sum()), "batches": k, "subsets": strata.subsets,
               "blur_sign": "exact_all_small - exact_emission", "energy_share": "per channel, averaged over RGB",
               "standard_errors": "delete-one jackknife over the paired batches (within each subset across the "
                                  "seeds where there are two or more); the reference's noise (its "
                                  "total's, from the measured total_variance_ratio) in quadrature where it enters",
               "reference_ratio": None if reference_ratio is None else [float(x) for x in reference_ratio]}
    return {"images": images, "terms": caustic_terms(images), "rows": rows, "residual": residual,
            "options": options}


class _Strata:
    """The batches' subsets as strata (module docstring, "Strata"): :meth:`centred` moves
    each subset's batches to the mean of all (its seeds' spread about their own mean
    kept), and ``factor`` scales what the independent-batch formulas then give, over the
    K − 1 degrees of freedom they assume, to the B(S − 1) the seeds within the subsets
    have. One seed (or ``subsets`` None): every batch its own unit, factor 1."""

    def __init__(self, k: int, subsets: int | None):
        if subsets is not None and (subsets < 1 or k % subsets):
            raise ValueError(f"subsets: {subsets}, expected a divisor of the {k} batches (seeds × subsets)")
        self.subsets, self.factor = None, 1.0
        if subsets is not None and k // subsets >= 2:
            self.subsets, self.factor = subsets, (k - 1) / (subsets * (k // subsets - 1))

    def centred(self, batches: np.ndarray) -> np.ndarray:
        """K×… batches with each subset's mean replaced by the mean of all (in their dtype:
        float32's rounding, 6e-8 of a value, is far below any batch's noise)."""
        if self.subsets is None:
            return batches
        by_subset = batches.reshape(-1, self.subsets, *batches.shape[1:])  # S×B×…
        shift = batches.mean(axis=0, dtype=np.float64) - by_subset.mean(axis=0, dtype=np.float64)
        return (by_subset + shift).astype(batches.dtype).reshape(batches.shape)


def _once(named: dict, f) -> dict:
    """name → f(value), f evaluated once per distinct value (by identity, tuples by their
    items'): the images a homogeneous medium aliases (A_m is A, E_∞,s,τ is E_∞,s) cost once."""
    done: dict = {}
    out = {}
    for name, value in named.items():
        key = tuple(map(id, value)) if isinstance(value, tuple) else id(value)
        if key not in done:
            done[key] = f(value)
        out[name] = done[key]
    return out


def _checked(batches: dict, reference, keep, reference_var) -> tuple:
    """(stacks: name → K×H×W×3, R as float64, keep, R's variance over the kept pixels), checked."""
    first = _stack(batches, BATCHED[0])
    stacks = {name: _stack(batches, name, first.shape) for name in BATCHED}
    if len(first) < 4:
        raise ValueError(f"batches: {len(first)} per image, expected at least 4 (the jackknife)")
    r_full = np.asarray(reference, np.float64)
    if r_full.shape != first.shape[1:] or not np.all(np.isfinite(r_full)):
        raise ValueError(f"reference: shape {r_full.shape}, expected finite {first.shape[1:]}")
    keep = np.ones(r_full.shape[:2], bool) if keep is None else np.asarray(keep, bool)
    if keep.shape != r_full.shape[:2]:
        raise ValueError(f"keep: shape {keep.shape}, expected {r_full.shape[:2]}")
    if not keep.any():
        raise ValueError("keep selects no pixel")
    if reference_var is None:
        return stacks, r_full, keep, np.zeros_like(r_full[keep])
    rv_full = np.asarray(reference_var, np.float64)
    if rv_full.shape != r_full.shape or not np.all(np.isfinite(rv_full)) or np.any(rv_full < 0):
        raise ValueError(f"reference_var: shape {rv_full.shape}, expected finite values ≥ 0 of shape "
                         f"{r_full.shape}")
    return stacks, r_full, keep, rv_full[keep]


class _Jackknife:
    """The kept pixels' batches (K×N×3) and their running sums: every reported number for
    the means of all batches or of all but one."""

    def __init__(self, kept: dict, sums: dict, r, channel_energy, energy2: float, reference_noise: float,
                 factor: float):
        self.kept, self.sums, self.r, self.factor = kept, sums, r, factor
        self.k = len(kept[BATCHED[0]])
        self.channel_energy, self.energy2, self.reference_noise = channel_energy, energy2, reference_noise
        self.small = kept[LAST]
        self.small_squares = np.square(self.small, dtype=np.float64).sum(axis=0)

    def numbers(self, means: dict) -> dict:
        """Every reported number for one set of mean images (N×3 kept pixels)."""
        r = self.r
        full = {**means, "reference": r}
        d = r - means["approx"]
        out = {}
        for name, (near, far) in list(TERMS.items()) + [("total", ("reference", "approx"))]:
            t = d if name == "total" else full[near] - full[far]  # the total is R − A itself
            out[name] = (float(np.mean(t.sum(axis=0) / self.channel_energy)), float(np.sum(t * d)) / self.energy2,
                         float(np.sum(t * t)) / self.energy2)
        out["debiased"] = (float(np.sum((r - means[LAST]) ** 2)) - self.reference_noise
                           - means["_small_noise"]) / self.energy2
        return out

    def means_without(self, i) -> dict:
        """The batches' means (and Σ of E_∞,s,τ's variance of the mean) without batch i
        (None: all), from running sums."""
        k, sums, kept, small = self.k, self.sums, self.kept, self.small
        n = k - (i is not None)
        m = _once({name: (sums[name], kept[name]) for name in BATCHED},
                  lambda pair: (pair[0] - pair[1][i]) / n if i is not None else pair[0] / n)
        s1 = sums[LAST] - (small[i] if i is not None else 0.0)
        s2 = self.small_squares - (np.square(small[i], dtype=np.float64) if i is not None else 0.0)
        m["_small_noise"] = self.factor * float(np.sum(s2 - s1 * s1 / n)) / (n - 1) / n
        return m


def _jackknife_se(leave_out: list, name: str, i=None) -> float:
    k = len(leave_out)
    v = np.array([x[name] if i is None else x[name][i] for x in leave_out])
    return float(np.sqrt((k - 1) / k * np.sum((v - v.mean()) ** 2)))


def _rows(jack: _Jackknife, value: dict, leave_out: list, rv, reference_ratio, reference_groups, keep) -> list:
    """One row per term and the total (values, SEs, debiased parts), then the noise row."""
    k, kept, sums, energy2, factor = jack.k, jack.kept, jack.sums, jack.energy2, jack.factor
    # R's noise where R enters (total, residual): its total's σ per channel, from Σ var and
    # the measured ratio of pixels covarying (channels of one photon are strongly
    # correlated: their σ add, an upper bound)
    ref_share_sigma = float(np.mean(total_sigma(rv, ratio=reference_ratio) / jack.channel_energy))
    rows = []
    for name in list(TERMS) + ["total"]:
        row: dict[str, Any] = {"term": name}
        for i, field in enumerate(("energy_share", "relmse_part", "relmse_own")):
            row[field] = value[name][i]
            row[f"{field}_se"] = _jackknife_se(leave_out, name, i) * np.sqrt(factor)
        if name in ("total", "residual"):
            row["energy_share_se"] = float(np.hypot(row["energy_share_se"], ref_share_sigma))
            reference_se = _reference_part_se(name, reference_groups, keep, jack.r, rv, sums, k, energy2)
            for field in ("relmse_part", "relmse_own") if name == "total" else ("relmse_part",):
                row[f"{field}_se"] = float(np.hypot(row[f"{field}_se"], reference_se))
        rows.append(row)
    # the parts less the noise each term shares with R − A: per batched image X, C(X) =
    # Σ cov(X̄, Ā) over the paired batches; a term near − far shares −(C(near) − C(far)),
    # and R's variance where R is in both (module docstring, "debiased parts")
    approx_dev = kept["approx"] - sums["approx"] / k
    shared = _once({name: (kept[name], sums[name]) for name in BATCHED},
                   lambda pair: factor * float(np.sum((pair[0] - pair[1] / k) * approx_dev)) / (k - 1) / k)
    shared["reference"] = 0.0
    for row in rows:
        near, far = TERMS.get(row["term"], ("reference", "approx"))
        own_reference = float(rv.sum()) if near == "reference" else 0.0
        row["relmse_part_debiased"] = row["relmse_part"] + (shared[near] - shared[far] - own_reference) / energy2
    approx_var = factor * kept["approx"].var(axis=0, ddof=1, dtype=np.float64) / k
    rows.append({"term": "noise", "energy_sigma": next(x for x in rows if x["term"] == "total")["energy_share_se"],
                 "relmse": (float(rv.sum()) + float(approx_var.sum())) / energy2})
    return rows


def _residual(res_row: dict, debiased: float, relmse_se: float, z_limit: float) -> dict:
    """The residual's energy and debiased relMSE with their z, whether both are within
    noise, and a message naming what disagrees when not."""
    residual = {"energy_share": res_row["energy_share"], "energy_se": res_row["energy_share_se"],
                "energy_z": _z(res_row["energy_share"], res_row["energy_share_se"]),
                "debiased_relmse": debiased, "relmse_se": relmse_se, "relmse_z": _z(debiased, relmse_se)}
    residual["within_noise"] = bool(abs(residual["energy_z"]) <= z_limit and residual["relmse_z"] <= z_limit)
    residual["message"] = "" if residual["within_noise"] else (
        f"the reference and the exact photons through the approximation's splatter disagree beyond their noise "
        f"(residual energy {100 * residual['energy_share']:+.2f}% of the reference, z = {residual['energy_z']:+.1f}; "
        f"debiased relative MSE {debiased:.2e}, z = {residual['relmse_z']:+.1f}; limit {z_limit:g}): one of "
        f"them is wrong — the reference light tracer, or the exact tracer and the splatter "
        f"(tests/cross/test_exact_photons_match_the_reference.py checks them against each other) — or a term is "
        f"missing: the terms do not explain the whole error (docs/decisions.md \"The emission term\")")
    return residual
