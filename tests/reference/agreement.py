"""Two estimates of one image from independent batches of ``mi.render``, and whether they
agree: the reference's validation tests share it."""

from __future__ import annotations

import numpy as np

from volcaustics.metrics.stats import z_test
from volcaustics.reference.mi_setup import mitsuba

mi = mitsuba()


class Batches(tuple):
    """(mean, variance of the mean) per pixel over independent batches of mi.render,
    with the batches' image totals (``totals``: B×C) beside."""

    totals: np.ndarray


def integrator_batches(mi_scene, integrator, spp, batches, channels, seed0=0) -> Batches:
    images = np.stack([np.asarray(mi.render(mi_scene, integrator=integrator, seed=seed0 + b, spp=spp))[..., channels]
                       for b in range(batches)]).astype(np.float64)
    out = Batches((images.mean(0), images.var(0, ddof=1) / batches))
    out.totals = images.sum(axis=(1, 2))
    return out


def agree(a: Batches, b: Batches) -> bool:
    """Two estimates of one image agree: per-pixel z-test (Student's t, Šidák), and the
    image totals within 3 standard errors per channel (from the batches' totals, which
    include the covariance of pixels one light path splats into). The totals give the
    power the per-pixel test lacks against a small global bias."""
    pixels = z_test(a[0], a[1], b[0], b[1], batches=(len(a.totals), len(b.totals)))
    se = np.sqrt(a.totals.var(0, ddof=1) / len(a.totals) + b.totals.var(0, ddof=1) / len(b.totals))
    totals = np.abs(a.totals.mean(0) - b.totals.mean(0)) <= 3.0 * se
    return pixels.passed and bool(np.all(totals))
