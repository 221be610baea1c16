"""Free flights and optical depths through a density grid, in numpy, for the exact replay.

* :func:`delta_track`: the GPU tracer's delta tracking (``approx/shaders/common/density.glsl``)
  step for step: regular tracking through the grid of majorants (``DensityGrid.majorants``),
  one unit exponential spent cell by cell, tentative collision k drawing its distance from
  u(seed, photon, step, TRACKING_DIM + 2k) and its acceptance from dim TRACKING_DIM + 2k + 1
  (``scenes.rng``), so that the exact replay draws the GPU's collisions (in float64 where the
  GPU computes in float32: a decision differs only where ξ·μ and ρ·rate agree to rounding).
* :func:`optical_depth`: ∫ρ ds along segments, exact to float64 rounding: ρ is trilinear
  between cell centres, so along a line it is a cubic between the planes through the centres
  (and the box's faces), where Simpson's rule is exact; the segment is cut at every such plane.
"""

from __future__ import annotations

import numpy as np

from .density import MAJORANT_BLOCK, DensityGrid
from .rng import MAX_TENTATIVE, TRACKING_DIM, uniform


def _box_interval(grid: DensityGrid, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit distances of rays o + t·d with the grid's box (entry clamped at 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        ta, tb = (grid.lo - o) * inv, (grid.hi - o) * inv
    ta, tb = np.nan_to_num(ta, nan=-np.inf), np.nan_to_num(tb, nan=np.inf)
    return np.maximum(np.minimum(ta, tb).max(axis=1), 0.0), np.maximum(ta, tb).min(axis=1)


def delta_track(grid: DensityGrid, o: np.ndarray, d: np.ndarray, t_max: np.ndarray, rate: float,
                seed: int | np.ndarray, photon: np.ndarray, step: int, *, block: int = MAJORANT_BLOCK) -> np.ndarray:
    """The first real collision on o + t·d, t < ``t_max`` (N), at rate ρ(x)·``rate`` (1/m),
    as the GPU draws it: N float64, −1 where none. ``seed``: one or N; ``photon``: N indices."""
    o, d = np.asarray(o, np.float64), np.asarray(d, np.float64)
    n = len(o)
    photon = np.asarray(photon).astype(np.uint32)
    seeds = np.broadcast_to(np.asarray(seed, np.uint32), (n,))
    majorants = grid.majorants(block)
    res = np.asarray(majorants.shape[::-1])  # (mx, my, mz)
    t_in, t_end = _box_interval(grid, o, d)
    t_end = np.minimum(t_end, t_max)
    out = np.full(n, -1.0)
    active = (t_in < t_end) & (rate > 0)
    cell_size = (grid.hi - grid.lo) / np.asarray(grid.resolution) * block
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
    with np.errstate(over="ignore", invalid="ignore"):  # a ray along a face: its lanes are not active
        start = (o + d * t_in[:, None] - grid.lo) / cell_size
        cell = np.clip(np.floor(start).astype(np.int64), 0, res - 1)
    stride = np.sign(d).astype(np.int64)
    next_plane = grid.lo + (cell + (d >= 0)) * cell_size
    moving = d != 0
    t_next = np.where(moving, (next_plane - o) * np.where(moving, inv, 0.0), np.inf)
    t_step = np.where(moving, np.abs(cell_size * np.where(moving, inv, 0.0)), np.inf)
    t = t_in.copy()
    tentative = np.zeros(n, np.int64)
    budget = -np.log(1.0 - uniform(seeds, photon, step, TRACKING_DIM).astype(np.float64))
    while active.any():
        i = np.flatnonzero(active)
        t_exit = np.minimum(t_next[i].min(axis=1), t_end[i])
        c = cell[i]
        mu = majorants[c[:, 2], c[:, 1], c[:, 0]].astype(np.float64) * rate
        inside = mu * (t_exit - t[i]) > budget[i]
        # a tentative collision in this cell
        j = i[inside]
        if len(j):
            t[j] += budget[j] / mu[inside]
            k = tentative[j]
            tentative[j] += 1
            xi = uniform(seeds[j], photon[j], step, TRACKING_DIM + 2 * k + 1).astype(np.float64)
            real = xi * mu[inside] < grid.eval(o[j] + d[j] * t[j, None]) * rate
            out[j[real]] = t[j[real]]
            active[j[real]] = False
            again = j[~real]
            budget[again] = -np.log(1.0 - uniform(seeds[again], photon[again], step,
                                                  TRACKING_DIM + 2 * tentative[again]).astype(np.float64))
            active[again] &= tentative[again] < MAX_TENTATIVE
        # no collision here: on to the next cell
        m = i[~inside]
        if len(m):
            budget[m] -= mu[~inside] * (t_exit[~inside] - t[m])
            t[m] = t_exit[~inside]
            axis = np.argmin(t_next[m], axis=1)
            cell[m, axis] += stride[m, axis]
            t_next[m, axis] += t_step[m, axis]
            left = (t[m] >= t_end[m]) | np.any((cell[m] < 0) | (cell[m] >= res), axis=1)
            active[m[left]] = False
    return out


def optical_depth(grid: DensityGrid, o: np.ndarray, d: np.ndarray, length: np.ndarray, *,
                  chunk: int = 4096) -> np.ndarray:
    """∫₀^length ρ(o + s·d) ds for N segments (d unit), exact to float64 rounding (module
    docstring): N float64, ≥ 0."""
    o, d = np.asarray(o, np.float64), np.asarray(d, np.float64)
    length = np.asarray(length, np.float64)
    out = np.zeros(len(o))
    h = (grid.hi - grid.lo) / np.asarray(grid.resolution)
    for lo in range(0, len(o), chunk):
        sl = slice(lo, lo + chunk)
        out[sl] = _depth(grid, o[sl], d[sl], np.maximum(length[sl], 0.0), h)
    return out


def _depth(grid: DensityGrid, o: np.ndarray, d: np.ndarray, length: np.ndarray, h: np.ndarray) -> np.ndarray:
    """:func:`optical_depth` of one chunk: the segment cut at every plane through cell centres
    and at the box's faces, Simpson's rule on each piece."""
    cuts = [np.zeros((len(o), 1)), length[:, None]]
    with np.errstate(divide="ignore", invalid="ignore"):
        for axis in range(3):
            a, b = o[:, axis], o[:, axis] + d[:, axis] * length
            # planes x = lo + (i + 1/2)·h for i = 0 … n−1, and the box's two faces
            first = np.ceil((np.minimum(a, b) - grid.lo[axis]) / h[axis] - 0.5)
            last = np.floor((np.maximum(a, b) - grid.lo[axis]) / h[axis] - 0.5)
            first = np.clip(first, 0, grid.resolution[axis] - 1)
            last = np.clip(last, -1, grid.resolution[axis] - 1)
            count = np.maximum(last - first + 1, 0).astype(np.int64)
            k = np.arange(max(int(count.max(initial=0)), 0))
            planes = grid.lo[axis] + (first[:, None] + k[None, :] + 0.5) * h[axis]
            t = np.where(k[None, :] < count[:, None], (planes - a[:, None]) / d[:, axis, None], np.nan)
            faces = (np.stack([np.full_like(a, grid.lo[axis]), np.full_like(a, grid.hi[axis])], axis=1)
                     - a[:, None]) / d[:, axis, None]
            cuts += [t, faces]
    breaks = np.concatenate(cuts, axis=1)
    breaks = np.where(np.isfinite(breaks) & (breaks >= 0.0) & (breaks < length[:, None]), breaks, length[:, None])
    breaks = np.sort(breaks, axis=1)  # the first is the zeros column's 0
    width = np.diff(breaks, axis=1)
    mid = breaks[:, :-1] + 0.5 * width
    row, piece = np.nonzero(width > 0.0)  # the pieces that are there (the rest pad the rows)
    centre = o[row] + d[row] * mid[row, piece, None]
    inside = np.all((centre >= grid.lo) & (centre <= grid.hi), axis=-1)  # a piece beyond a face holds ρ = 0
    row, piece, centre = row[inside], piece[inside], centre[inside]

    def rho(s: np.ndarray) -> np.ndarray:
        # a piece inside the box ends on its face at most: clamped there, rounding cannot put the end outside
        return grid.eval(np.clip(o[row] + d[row] * s[:, None], grid.lo, grid.hi))

    simpson = width[row, piece] / 6.0 * (rho(breaks[row, piece]) + 4.0 * grid.eval(centre)
                                         + rho(breaks[row, piece + 1]))
    return np.bincount(row, weights=simpson, minlength=len(o))
