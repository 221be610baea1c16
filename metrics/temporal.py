"""Temporal error: how a sequence's frame-to-frame change differs from the reference's
(docs/over-time.md. Pure numpy, float64 accumulation.

With ΔX_t = X_t − X_{t−1}, the flicker of a pair is Σ(ΔA − ΔR)² / Σ R² over the compared
pixels, Σ R² the mean of the two reference frames' energies. A reference frame R̂_t is
an unbiased estimate with a known per-pixel variance v_t (of its mean), independent
between frames, so E Σ(ΔA − ΔR̂)² = Σ(ΔA − ΔR)² + Σ(v_t + v_{t−1}): that much is
subtracted (``reference_noise``). What remains is what a viewer sees change wrongly:
the approximation's own frame-to-frame noise (a new seed every frame) plus the
systematic part (caustics that swim over the photon grid, beams that pop). With S ≥ 2
independent chains of the approximation (each a whole sequence with its own seeds),
the chains' spread estimates the noise part, and ``systematic`` = flicker − noise is
what no seed averaging removes. A test sequence that is itself a Monte Carlo estimate
with known per-pixel variance (a second reference) may pass ``test_var``: its noise is
then subtracted as well, so two references of the same frames score 0 within noise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from volcaustics.metrics.groups import group_jackknife_se
from volcaustics.metrics.noise import total_sigma

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    class _FrameGroups(Protocol):
        """``flicker``'s reference_groups: per frame None or (means, counts, variance), read on indexing."""

        def __len__(self) -> int: ...

        def __getitem__(self, t: int, /) -> tuple[ArrayLike, ArrayLike, ArrayLike] | None: ...

NAN = float("nan")


@dataclass(frozen=True)
class PairFlicker:
    """One frame pair (t − 1, t) of :func:`flicker`. Fractions of the pair's Σ R².

    raw: mean over chains of Σ(ΔA − ΔR̂)²; reference_noise: Σ(v_t + v_{t−1});
    flicker = raw − reference_noise (− the test's own Σ var when ``test_var`` is given);
    test_noise: the approximation's frame-to-frame noise, Σ var over chains of ΔA
    (nan with one chain and no test_var); systematic = flicker − test_noise (with
    ``test_var``: flicker itself); standard_error of ``flicker``, z = flicker / SE.
    """

    frame: int
    raw: float
    reference_noise: float
    test_noise: float
    flicker: float
    systematic: float
    standard_error: float
    z: float
    energy: float
    pixels: int
    chains: int


def flicker(reference: ArrayLike, reference_var: ArrayLike, chains: ArrayLike, *, test_var: ArrayLike | None = None,
            mask: ArrayLike | None = None, reference_groups: _FrameGroups | None = None) -> list[PairFlicker]:
    """Flicker of every frame pair of a sequence against its reference.

    Parameters
    ----------
    reference : T×H×W×C reference frames (means), linear radiance.
    reference_var : T×H×W×C, the variance of each reference pixel's mean.
    chains : S×T×H×W×C approximation frames: S independent sequences (seeds).
    test_var : optional T×H×W×C per-pixel variance of a Monte Carlo test's frames
        (then S must be 1): its noise is subtracted too.
    mask : optional T×H×W booleans: the pixels compared in each frame (a pair compares
        the pixels kept in both of its frames).
    reference_groups : optional sequence over the frames, each None or (G×H×W×C means of
        G ≥ 4 independent groups of the batches of the part of R_t whose pixels covary —
        the light tracer's caustic —, their G batch counts, that part's H×W×C variance of
        the mean); R_t is that part plus the rest (``reference`` less the groups' mean).
        Read lazily, frame by frame (a sequence that loads on indexing will do).

    Standard error: the chains are independent given R̂, so the spread of the chains'
    Σ(ΔA − ΔR̂)² over √S gives their part (S ≥ 2); R̂'s own noise, shared by the
    chains, adds 4 Σ b̂² v + 2 Σ v² (v = v_t + v_{t−1}, b̂² = d̄² − v clipped at 0,
    Gaussian pixel noise); with ``test_var`` the test's variance joins v. Where both
    frames of a pair have ``reference_groups``, the grouped part's share of that is a
    delete-one-group jackknife instead (``metrics.groups``: R's covarying pixels), the
    rest's (and the cross terms) stay analytic. With one chain
    and no ``test_var`` the SE is conditional on the approximation's frames. A pair whose
    reference is zero over the compared pixels (a light blocked in both frames) has NaN
    values: its flicker is undefined.
    """
    r, rv, a = (np.asarray(x, np.float64) for x in (reference, reference_var, chains))
    if r.ndim != 4 or rv.shape != r.shape or a.ndim != 5 or a.shape[1:] != r.shape:
        raise ValueError(f"shapes: reference {r.shape}, reference_var {rv.shape}, chains {a.shape} "
                         "(expected T×H×W×C, T×H×W×C, S×T×H×W×C)")
    if len(r) < 2:
        raise ValueError(f"{len(r)} frame(s): flicker needs at least 2")
    tv = None if test_var is None else np.asarray(test_var, np.float64)
    if tv is not None and (tv.shape != r.shape or len(a) != 1):
        raise ValueError("test_var: expected T×H×W×C like the reference, with one chain")
    keep = np.ones(r.shape[:3], bool) if mask is None else np.asarray(mask, bool)
    if keep.shape != r.shape[:3]:
        raise ValueError(f"mask shape {keep.shape}: expected {r.shape[:3]}")
    groups = [None] * len(r) if reference_groups is None else reference_groups
    if len(groups) != len(r):
        raise ValueError(f"reference_groups: {len(groups)} frames, expected {len(r)}")
    out, previous = [], groups[0]
    for t in range(1, len(r)):
        current = groups[t]
        pair_groups = None if previous is None or current is None else (previous, current)
        out.append(_pair(t, r, rv, a, tv, keep[t] & keep[t - 1], pair_groups))
        previous = current
    return out


def _noise_variance(bias2_weights, v) -> float:
    """4 Σ b̂² v + 2 Σ v²: the variance of Σ(d + n)² that Gaussian pixel noise n of
    variance v gives, b̂² = ``bias2_weights``."""
    return 4.0 * float(np.sum(bias2_weights * v)) + 2.0 * float(np.sum(v * v))


def _grouped_variance(t, r, keep, delta_a, groups) -> tuple:
    """(the delete-one-group jackknife variance of the pair's Σ(ΔA − ΔR̂)² less R's
    noise, as R's grouped part varies; that part's per-pixel variance v_g of ΔR̂)."""
    (m0, c0, v0), (m1, c1, v1) = groups
    rest = [r[t - 1] - np.tensordot(np.asarray(c0, np.float64), m0, axes=1) / np.sum(c0),
            r[t] - np.tensordot(np.asarray(c1, np.float64), m1, axes=1) / np.sum(c1)]
    v_grouped = [np.asarray(v0, np.float64)[keep], np.asarray(v1, np.float64)[keep]]

    def statistic(images, scales):
        d_ref = ((images[1] + rest[1]) - (images[0] + rest[0]))[keep]
        d = delta_a - d_ref
        return float(np.sum(d * d, axis=(1, 2)).mean()) - float(np.sum(v_grouped[0]) * scales[0]
                                                                 + np.sum(v_grouped[1]) * scales[1])

    jackknife = group_jackknife_se([(m0, c0), (m1, c1)], statistic) ** 2
    return jackknife, v_grouped[0] + v_grouped[1]


def _pair(t, r, rv, a, tv, keep, groups=None) -> PairFlicker:
    s = len(a)
    energy = 0.5 * float(np.sum(r[t][keep] ** 2) + np.sum(r[t - 1][keep] ** 2))
    if energy == 0.0:  # nothing to compare against (a light blocked in both frames): undefined, not an error
        return PairFlicker(frame=t, raw=NAN, reference_noise=NAN, test_noise=NAN, flicker=NAN, systematic=NAN,
                           standard_error=NAN, z=NAN, energy=0.0, pixels=int(keep.sum()), chains=s)
    d_ref = (r[t] - r[t - 1])[keep]
    v = (rv[t] + rv[t - 1])[keep]
    delta_a = np.stack([(c[t] - c[t - 1])[keep] for c in a])  # S×N×C: ΔA per chain
    d = delta_a - d_ref  # ΔA − ΔR̂ per chain
    per_chain = np.sum(d * d, axis=(1, 2))
    raw, ref_noise = float(per_chain.mean()), float(v.sum())
    v_test = None if tv is None else (tv[t] + tv[t - 1])[keep]
    if v_test is not None:
        test_noise = float(v_test.sum())
    elif s >= 2:
        test_noise = float(np.sum(np.var(d, axis=0, ddof=1)))  # the chains' spread: ΔA's own variance
    else:
        test_noise = NAN
    value = raw - ref_noise - (test_noise if v_test is not None else 0.0)
    systematic = value if v_test is not None else value - test_noise
    v_all = v + (v_test if v_test is not None else 0.0)
    bias2 = np.maximum(np.mean(d, axis=0) ** 2 - v_all, 0.0)
    variance = _noise_variance(bias2, v_all)
    if groups is not None:  # R's grouped part by the jackknife, the rest (and cross terms) analytic
        jackknife, v_grouped = _grouped_variance(t, r, keep, delta_a, groups)
        variance += jackknife - _noise_variance(bias2, v_grouped)
    if s >= 2:
        variance += float(per_chain.var(ddof=1)) / s
    se = float(np.sqrt(variance))
    z = value / se if se > 0 else (0.0 if value == 0 else float(np.copysign(np.inf, value)))
    return PairFlicker(frame=t, raw=raw / energy, reference_noise=ref_noise / energy, test_noise=test_noise / energy,
                       flicker=value / energy, systematic=systematic / energy, standard_error=se / energy, z=z,
                       energy=energy, pixels=int(keep.sum()), chains=s)


def energy_jitter(reference: ArrayLike, reference_var: ArrayLike, chains: ArrayLike, *, mask: ArrayLike | None = None,
                  ratios: Sequence[ArrayLike | None] | None = None) -> list[dict]:
    """The energy ratio's frame-to-frame change: per frame t, e_t = Σ Ā_t / Σ R̂_t over the
    kept pixels (channels averaged, Ā the chains' mean) and per pair Δe = e_t − e_{t−1},
    with the SE of Δe that the reference totals' noise gives (``metrics.noise.total_sigma``
    with frame t's ``ratios[t]``, its total_variance_ratio; None: pixels independent)
    and the chains' spread adds (S ≥ 2). Rows: {"frame", "energy_ratio", "jitter",
    "jitter_se"} (jitter nan for frame 0; all nan where the reference total is not positive
    in every channel, and the jitter beside such a frame)."""
    r, rv, a = (np.asarray(x, np.float64) for x in (reference, reference_var, chains))
    keep = np.ones(r.shape[:3], bool) if mask is None else np.asarray(mask, bool)
    rows, previous = [], None
    for t in range(len(r)):
        ref_total = r[t][keep[t]].sum(axis=0)
        if np.any(ref_total <= 0):  # a ratio to nothing: undefined here and in the jitters beside it
            rows.append({"frame": t, "energy_ratio": NAN, "jitter": NAN, "jitter_se": NAN})
            previous = (NAN, NAN)
            continue
        per_chain = np.array([c[t][keep[t]].sum(axis=0) / ref_total for c in a]).mean(axis=1)
        ratio = float(per_chain.mean())
        sigma = total_sigma(rv[t], mask=keep[t], ratio=None if ratios is None else ratios[t])
        var = float(np.mean(sigma ** 2 / ref_total ** 2)) * ratio ** 2
        if len(a) >= 2:
            var += float(per_chain.var(ddof=1)) / len(a)
        if previous is None:
            jitter, se = NAN, NAN
        else:
            jitter, se = ratio - previous[0], float(np.sqrt(var + previous[1]))
        rows.append({"frame": t, "energy_ratio": ratio, "jitter": jitter, "jitter_se": se})
        previous = (ratio, var)
    return rows


def trailing_lag(frames: ArrayLike, references: ArrayLike, *, mask: ArrayLike | None = None,
                 max_shift: int = 4) -> int:
    """How many frames a sequence trails its reference: the shift s in 0 … max_shift
    that minimises Σ_t Σ(A_t − R_{t−s})² / Σ R_{t−s}² over the frames both cover
    (``frames``, ``references``: T×H×W×C; ``mask``: T×H×W). 0 for a filter without
    lag; an average over past frames that trails a moving caustic scores its delay."""
    a, r = np.asarray(frames, np.float64), np.asarray(references, np.float64)
    m = np.ones(a.shape[:3], bool) if mask is None else np.asarray(mask, bool)
    k = min(max_shift, len(a) - 2)
    best, best_error = 0, float("inf")
    for s in range(0, k + 1):
        errors = []
        for t in range(k, len(a)):
            both = m[t] & m[t - s]
            errors.append(np.sum(((a[t] - r[t - s]) ** 2)[both]) / max(np.sum((r[t - s] ** 2)[both]), 1e-30))
        error = float(np.mean(errors)) if errors else float("inf")
        if error < best_error:
            best, best_error = s, error
    return best


def recovery_frames(errors: Sequence[float] | np.ndarray, change: int, without_history: ArrayLike, *,
                    factor: float = 1.0) -> int:
    """Frames after ``change`` until a per-frame error series first comes back within
    ``factor`` × the error the frames have without history (``without_history``: that
    series, or its level): how long a temporal filter ghosts after a change.
    len(errors) − change when it never does."""
    level = np.broadcast_to(np.asarray(without_history, float), np.shape(errors))
    for k in range(change, len(errors)):
        if errors[k] <= factor * level[k]:
            return k - change
    return len(errors) - change
