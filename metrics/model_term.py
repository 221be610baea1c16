"""The model term: how far the paper's single-scattering model is from K scattering
orders (docs/concepts/model-term.md, per component (pure numpy, float64).

With R_ss the reference of the paper's model, T = R_ms − R_ss what the higher orders
add (the reference's ``<component>_ms`` layer) and A the approximation (mean over its
seeds), over the compared pixels:

* ``energy_share`` Σ T / Σ R_ms per channel, averaged over RGB: the light the model
  leaves out;
* ``relmse_own`` Σ T² / Σ R_ms², debiased by T's variance (Σ var T / Σ R_ms²): the
  relative MSE of a perfect single-scattering renderer against the physics, the error
  no knob of the approximation removes;
* ``relmse_part`` Σ T · (R_ms − A) / Σ R_ms²: the term's part of the approximation's
  relative MSE against R_ms, as the decomposition's terms are parts of its error
  (``metrics.decomposition``), debiased by T's variance too (R_ms = R_ss + T holds T, so
  the sum holds Σ T², whose expectation exceeds the noiseless one by Σ var T);
  ``approx_part`` Σ (R_ss − A)(R_ms − A) / Σ R_ms² is the approximation's own part, and
  the two values sum to Σ (R_ms − A)² / Σ R_ms².

Standard errors by first-order propagation of the per-pixel variances (T's, R_ss's and
A's over its seeds), a pixel's three channels taken as fully correlated (one light
path carries all three) and pixels as independent, except where the reference says
how its pixels covary (the higher orders come from a light tracer, whose photons reach
many pixels): the energy share scales T's variance by its measured ratio of the
total's variance to Σ var, and with T's batch groups (and R_ss's, for the caustic) the
relMSE values' reference part is a delete-one-group jackknife (``metrics.groups``); the
intervals are ±1.96 SE (normal).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, cast

import numpy as np

from volcaustics.metrics.groups import group_jackknife_se

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

Z95 = 1.959963984540054  # two-sided 95% normal quantile


def _sel(image, keep):
    return np.asarray(image, np.float64)[keep]


def _propagated(gradient, variance) -> float:
    """Σ over pixels of (Σ over channels |∂/∂x_c| σ_c)²: the variance of a sum of
    per-pixel terms whose channels share their noise."""
    return float(np.sum(np.sum(np.abs(gradient) * np.sqrt(variance), axis=1) ** 2))


def model_term(r_ss: ArrayLike, r_ss_var: ArrayLike, term: ArrayLike, term_var: ArrayLike,
               approx_stack: Iterable[ArrayLike], keep: np.ndarray, term_ratio: ArrayLike | None = None,
               term_groups: tuple[ArrayLike, ArrayLike] | None = None,
               reference_groups: tuple[ArrayLike, ArrayLike] | None = None) -> dict:
    """The model term's numbers for one component (module docstring): {metric: (value,
    debiased, standard error)}. ``approx_stack``: S×H×W×3 frames (S ≥ 1; with S ≥ 2
    their variance over the seeds enters the SE); ``keep``: H×W compared pixels;
    ``term_ratio``: per channel, the variance of T's total over Σ of its pixels'
    (``metrics.noise.total_sigma``; None: 1), for the energy share's SE;
    ``term_groups``, ``reference_groups``: (G×H×W×3 means, G counts) of T's and of R_ss's
    batch groups (None: pixels independent), for the relMSE values' SEs.
    ValueError when R_ms has no energy there."""
    r, rv, t, tv = _sel(r_ss, keep), _sel(r_ss_var, keep), _sel(term, keep), _sel(term_var, keep)
    stack = np.stack([_sel(a, keep) for a in approx_stack])
    a = stack.mean(axis=0)
    av = stack.var(axis=0, ddof=1) / len(stack) if len(stack) >= 2 else np.zeros_like(a)
    ms = r + t
    energy, totals = float(np.sum(ms * ms)), ms.sum(axis=0)
    if energy <= 0 or np.any(totals <= 0):
        raise ValueError("the reference with its higher orders is black in some channel over the compared pixels")
    share = float(np.mean(t.sum(axis=0) / totals))
    ratio = 1.0 if term_ratio is None else np.asarray(term_ratio, np.float64)
    # ∂ share / ∂T = (Σ R_ss / (Σ R_ms)²) / 3 per channel: T is in Σ R_ms too
    share_se = math.sqrt(_propagated(np.broadcast_to(r.sum(axis=0) / (3.0 * totals ** 2), t.shape), tv * ratio))
    own = float(np.sum(t * t)) / energy
    own_debiased = own - float(np.sum(tv)) / energy
    own_se = math.sqrt(_propagated(2.0 * t, tv)) / energy
    err_ms = ms - a
    part = float(np.sum(t * err_ms)) / energy
    # ∂ part / ∂T = (R_ms − A) + T, ∂ part / ∂A = −T, ∂ part / ∂R_ss = T (independent sources)
    part_se = math.sqrt(_propagated(err_ms + t, tv) + _propagated(t, av) + _propagated(t, rv)) / energy
    if term_groups is not None:  # the reference's part from its groups, A's (and R_ss's without groups) analytic
        grouped = [(np.asarray(g[0], np.float64)[:, keep], g[1]) for g in (term_groups, reference_groups)
                   if g is not None]
        noise = float(np.sum(tv))

        def values(images, scales):
            t_g, r_g = images[0], images[1] if len(images) > 1 else r
            ms_g = r_g + t_g
            e_g = float(np.sum(ms_g * ms_g))
            return (float(np.sum(t_g * t_g)) - noise * scales[0]) / e_g, \
                (float(np.sum(t_g * (ms_g - a))) - noise * scales[0]) / e_g

        rest = _propagated(t, av) + (_propagated(t, rv) if reference_groups is None else 0.0)
        own_se, part_se = (float(x) for x in cast(np.ndarray, group_jackknife_se(grouped, values)))  # two SEs
        part_se = math.sqrt(part_se**2 + rest / energy**2)
    approx_part = float(np.sum((r - a) * err_ms)) / energy
    return {"energy_share": (share, share, share_se),
            "relmse_own": (own, own_debiased, own_se),
            "relmse_part": (part, part - float(np.sum(tv)) / energy, part_se),
            "approx_part": (approx_part, approx_part, float("nan"))}


def interval(value: float, se: float) -> tuple:
    """The 95% normal interval value ± 1.96 SE."""
    return value - Z95 * se, value + Z95 * se
