"""The delete-one-group jackknife over a reference's batch groups (pure numpy, float64).

A light tracer's photon reaches many pixels (a medium segment is drawn along its
streak), so the reference's pixels covary, and a standard error built from per-pixel
variances alone understates the noise of anything summed over pixels (the batch-total
variance of the caustic is 9–20× the sum of its pixel variances). The reference also
keeps its batches summed in G independent groups (``reference.render.batches.
BatchStats``): a statistic recomputed with each group left out varies as the whole
does, covariance included (Quenouille–Tukey jackknife; for a statistic quadratic in
pure noise it errs on the large side, the Efron–Stein bias: docs/decisions.md
"Jackknife calibration").
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

MIN_GROUPS = 4


def checked_groups(groups: tuple[ArrayLike, ArrayLike], name: str = "reference_groups") -> tuple:
    """(G×… float64 means, G float64 batch counts) of ``groups``; ValueError unless at
    least MIN_GROUPS groups with a batch each."""
    means, counts = groups
    means, counts = np.asarray(means, np.float64), np.asarray(counts, np.float64)
    if len(means) < MIN_GROUPS or counts.shape != (len(means),) or np.any(counts <= 0):
        raise ValueError(f"{name}: {len(means)} groups with counts {counts}, expected at least {MIN_GROUPS} "
                         f"with a batch each")
    return means, counts


def group_jackknife_se(groups: list, statistic: Callable[[list[np.ndarray], list[float]], float | Sequence[float]]
                       ) -> float | np.ndarray:
    """The delete-one-group jackknife SE of ``statistic(images, scales)`` (a number, or a
    sequence of numbers: their SEs as an array, from one pass over the groups).

    groups : one (means, counts) per independent image (each G groups, the same G): the
        replicate g leaves group g out of every image at once (the images' groups are
        independent, so the tuples of their g-th groups are too).
    statistic : called per replicate with the images without their group g (each the
        count-weighted mean of the other groups) and per image n/(n − c_g), the factor by
        which a per-pixel variance of the whole's mean grows without group g (for
        debiasing inside the statistic).
    """
    checked = [checked_groups(g) for g in groups]
    n_groups = len(checked[0][0])
    if any(len(means) != n_groups for means, _ in checked):
        raise ValueError(f"reference_groups: {[len(m) for m, _ in checked]} groups, expected the same number in each")
    wholes = [(np.tensordot(counts, means, axes=1), counts.sum()) for means, counts in checked]

    def replicate(g):
        images = [(whole - counts[g] * means[g]) / (n - counts[g]) for (means, counts), (whole, n)
                  in zip(checked, wholes)]
        return statistic(images, [n / (n - counts[g]) for (_, counts), (_, n) in zip(checked, wholes)])

    leave = np.array([replicate(g) for g in range(n_groups)], np.float64)  # G, or G×m for m statistics
    se = np.sqrt((n_groups - 1) / n_groups * np.sum((leave - leave.mean(axis=0)) ** 2, axis=0))
    return float(se) if se.ndim == 0 else se
