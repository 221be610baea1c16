"""Running statistics of independent batch images, and the noise floor they give.

A reference renders independent streams of batches: the light tracer's
(``caustic``), the camera integrator's (``fog``, ``direct``) and, with K > 1
scattering orders, the higher orders' (``reference.render.orders``). Each stream
keeps, per image, the float64 sums of the batch images and of their squares, in
batch order, so a cached render can be continued batch by batch and gives
exactly what rendering all its batches at once gives (same seeds, same order of
additions). The variance of the mean is the batches' sample variance over n.

It also keeps each batch's image total per channel (over the pixels that do not see
glass, those the metrics compare). Their spread is the variance of
the image's energy, which the per-pixel variances give only where pixels are
independent: a light-tracer photon lands on many pixels (a medium segment is drawn
along its streak), so its pixels covary, and Σ var understates the energy's variance
by the factor :func:`total_variance_ratio` gives (docs/decisions.md "The
reference's energy noise").

The noise floor of a component is Σ var / Σ mean² over the pixels that do not
see glass (docs/concepts/measuring.md: the relative MSE an exact renderer would get
against this reference).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from volcaustics.scenes.rng import pcg_hash

LIGHT, CAMERA, ORDERS = "light", "camera", "orders"
# The light stream's batches also sum in 8 groups: independent estimates of the caustic
# whose spread holds its pixels' covariance (metrics.groups: the residual's, the flicker's
# and the model term's SEs); the orders stream's (a light tracer too) for its model terms
LIGHT_GROUPS = 8
STREAM_IMAGES = {LIGHT: ("caustic",), CAMERA: ("fog", "direct", "fog_direct")}  # ORDERS: orders.stream_images(K)
# Salt of each stream's batch seeds, so that no two streams share one.
_STREAM_SALT = {LIGHT: 1, CAMERA: 2, ORDERS: 3}


def batch_seed(seed: int, stream: str, batch: int) -> int:
    """Mitsuba seed (uint32) of batch ``batch`` of ``stream`` for the settings' ``seed``:
    a PCG hash chain (scenes.rng), independent of how many batches are rendered, so that
    batch b is the same image whether it is rendered first or as a continuation."""
    v = pcg_hash(np.uint32(seed) + pcg_hash(np.uint32(_STREAM_SALT[stream])))
    return int(pcg_hash(v + np.uint32(batch)))


class BatchStats:
    """Sums over n batches of named H×W×3 images (float64) and of their squares; with
    ``groups`` G > 0 also the sums of G groups of batches (batch b in group b mod G) of
    the names in ``grouped`` (None: every name)."""

    def __init__(self, names, n: int = 0, sums: dict | None = None, squares: dict | None = None,
                 totals: dict | None = None, groups: int = 0, group_sums: dict | None = None,
                 grouped: tuple | None = None):
        self.names = tuple(names)
        self.grouped = self.names if grouped is None else tuple(grouped)
        self.n = n
        self.sums = sums or {}
        self.squares = squares or {}
        self.totals = totals or {}  # name -> n×3 float64: each batch's image total per channel
        self.groups = groups
        self.group_sums = group_sums or {}  # name -> G×H×W×3 float64

    def add(self, images: dict, keep: np.ndarray | None = None) -> None:
        """Add one batch: ``images`` maps every name to an H×W×3 array; its totals are
        over the pixels ``keep`` (H×W bool, the same for every batch; None: all)."""
        for name in self.names:
            x = np.asarray(images[name], np.float64)
            if name in self.sums:
                self.sums[name] += x
                self.squares[name] += x * x
            else:
                self.sums[name], self.squares[name] = x.copy(), x * x
            total = (x.sum(axis=(0, 1)) if keep is None else x[keep].sum(axis=0))[None]
            self.totals[name] = total if name not in self.totals else np.concatenate([self.totals[name], total])
            if self.groups and name in self.grouped:
                if name not in self.group_sums:
                    self.group_sums[name] = np.zeros((self.groups, *x.shape))
                self.group_sums[name][self.n % self.groups] += x
        self.n += 1

    def group_means(self, name: str) -> tuple | None:
        """(G×H×W×3 means of the groups, their G batch counts), or None without groups or
        before every group has a batch: independent estimates of the image whose spread
        holds all the covariance of its pixels."""
        if not self.groups or self.n < self.groups or name not in self.group_sums:
            return None
        return _group_means(self.group_sums[name], self.n, self.groups)

    def mean(self, name: str) -> np.ndarray:
        return self.sums[name] / self.n

    def var(self, name: str) -> np.ndarray:
        """Variance of the mean per pixel (needs n ≥ 2), float64, ≥ 0."""
        n = self.n
        spread = self.squares[name] - self.sums[name] * self.sums[name] / n
        return np.maximum(spread, 0.0) / (n - 1) / n

    def arrays(self, prefix: str) -> dict:
        """The state as flat arrays (for an .npz file)."""
        out = {f"{prefix}/n": np.asarray(self.n)}
        for name in self.sums:
            out[f"{prefix}/sum/{name}"] = self.sums[name]
            out[f"{prefix}/square/{name}"] = self.squares[name]
            out[f"{prefix}/total/{name}"] = self.totals[name]
            if name in self.group_sums:
                out[f"{prefix}/group/{name}"] = self.group_sums[name]
        if self.groups:
            out[f"{prefix}/groups"] = np.asarray(self.groups)
        return out

    @staticmethod
    def stored_group_means(arrays: Mapping[str, np.ndarray], prefix: str, name: str, groups: int) -> tuple | None:
        """:meth:`group_means` of ``name`` from the arrays :meth:`arrays` wrote (only the
        group sums and the counts read), or None (none stored, fewer batches than
        groups; ValueError: stored with another number of groups)."""
        n = int(arrays[f"{prefix}/n"])
        stored = int(arrays.get(f"{prefix}/groups", 0))
        if stored != groups:
            raise ValueError(f"{prefix}: stored with {stored} batch groups, not {groups}")
        key = f"{prefix}/group/{name}"
        if not groups or n < groups or key not in arrays:
            return None
        return _group_means(np.array(arrays[key], np.float64), n, groups)

    @classmethod
    def from_arrays(cls, names: Sequence[str], arrays: Mapping[str, np.ndarray], prefix: str, groups: int = 0,
                    grouped: tuple | None = None) -> "BatchStats":
        """The state ``arrays`` wrote, for ``groups`` groups of ``grouped`` (ValueError:
        stored with others)."""
        n = int(arrays[f"{prefix}/n"])
        if n == 0:
            return cls(names, groups=groups, grouped=grouped)
        stored = int(arrays.get(f"{prefix}/groups", 0))
        if stored != groups:
            raise ValueError(f"{prefix}: stored with {stored} batch groups, not {groups}")
        totals = {k: np.array(arrays[f"{prefix}/total/{k}"], np.float64) for k in names}
        if any(t.shape != (n, 3) for t in totals.values()):
            raise ValueError(f"{prefix}: batch totals of another shape than ({n}, 3)")
        grouped = tuple(names) if grouped is None else tuple(grouped)
        group_sums = {k: np.array(arrays[f"{prefix}/group/{k}"], np.float64) for k in grouped} if groups else None
        return cls(names, n, {k: np.array(arrays[f"{prefix}/sum/{k}"], np.float64) for k in names},
                   {k: np.array(arrays[f"{prefix}/square/{k}"], np.float64) for k in names}, totals, groups,
                   group_sums, grouped)


def _group_means(group_sums: np.ndarray, n: int, groups: int) -> tuple:
    """(G×… means, G counts) of group sums over n batches dealt round-robin."""
    counts = np.array([n // groups + (g < n % groups) for g in range(groups)])
    return group_sums / counts.reshape(-1, *([1] * (group_sums.ndim - 1))), counts


def noise_floor(mean: np.ndarray, var: np.ndarray, keep: np.ndarray) -> float | None:
    """Σ var / Σ mean² over the pixels ``keep`` (H×W bool); None where the component
    has no energy there (nothing to estimate: vacuum fog, no diffuse surface)."""
    energy = float(np.sum(mean[keep] ** 2))
    return float(np.sum(var[keep]) / energy) if energy > 0 else None


def total_variance_ratio(*parts: tuple[BatchStats, str], keep: np.ndarray | None = None) -> list | None:
    """Per channel, the variance of an image's total over Σ of its per-pixel variances
    (both of the mean, over the pixels ``keep`` the totals were taken over; None: all):
    1 for independent pixels, more where one sample reaches many pixels. The image is
    the sum of ``parts``, (BatchStats, name) pairs of independent streams (one pair, or
    e.g. the caustic and fog + direct for ``combined``). None before 2 batches or where
    the image is noiseless in a channel."""
    if min(stats.n for stats, _ in parts) < 2:
        return None
    total_var = sum(stats.totals[name].var(axis=0, ddof=1) / stats.n for stats, name in parts)
    pixel_var = sum((stats.var(name) if keep is None else stats.var(name)[keep]).reshape(-1, 3).sum(axis=0)
                    for stats, name in parts)
    if not np.all(pixel_var > 0):
        return None
    return [float(v) for v in total_var / pixel_var]
