"""A density grid in the exact replay's Dr.Jit steps (``reference.wavefront``).

The numpy twins (``scenes.density.DensityGrid.eval``, ``scenes.tracking.delta_track`` and
``scenes.tracking.optical_depth``) as Dr.Jit arrays of the oracle's variant: each a symbolic
loop (one kernel), with the twins' float64 operations in their order, so that a replay on the
device draws the twins' collisions and carries their transmittance (a test holds the engines
to the same rows):

* ρ(x): trilinear between cell centres, summed in the twin's order;
* delta tracking: regular tracking through the majorant grid, one unit exponential spent cell
  by cell, tentative collision k drawing dims TRACKING_DIM + 2k and TRACKING_DIM + 2k + 1 of
  u(seed, photon, step, ·), as the GPU does;
* the optical depth: Simpson's rule on each piece between the planes through cell centres
  and the box's faces (exact: ρ is a cubic there), the pieces visited in the order the twin
  sorts them and summed in that order.

Dr.Jit's float64 ``log`` may differ from numpy's in the last bit; a tracking decision it
could turn lies within that bit of its threshold, and the records keep float32.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from volcaustics.scenes.density import MAJORANT_BLOCK, DensityGrid
from volcaustics.scenes.rng import MAX_TENTATIVE, TRACKING_DIM


class GridWavefront:
    """One density grid on the device: ρ, free flights by delta tracking, optical depths.

    ``types``: the variant's (dr, F64, V64, U32, I32, F32); ``uniform(seed, photon,
    step, dim)``: ``scenes.rng.uniform`` as Dr.Jit float32 (``Wavefront.uniform``)."""

    def __init__(self, grid: DensityGrid, types: tuple, uniform, *, block: int = MAJORANT_BLOCK):
        self.dr, self.F64, self.V64, self.U32, self.I32, self.F32 = types
        self.uniform = uniform
        self.lo = [float(x) for x in grid.lo]
        self.hi = [float(x) for x in grid.hi]
        self.res = [int(n) for n in grid.resolution]  # (nx, ny, nz)
        self.extent = [float(x) for x in np.asarray(grid.hi) - np.asarray(grid.lo)]
        self.h = [float(x) for x in (np.asarray(grid.hi) - np.asarray(grid.lo)) / np.asarray(grid.resolution)]
        self.values = self.F64(grid.values.astype(np.float64).ravel())
        majorants = grid.majorants(block)
        self.m_res = [int(n) for n in majorants.shape[::-1]]  # (mx, my, mz)
        self.majorants = self.F32(majorants.ravel())
        self.cell_size = [float(x) for x in (np.asarray(grid.hi) - np.asarray(grid.lo))
                          / np.asarray(grid.resolution) * block]

    # --- ρ ------------------------------------------------------------------------------
    def eval(self, p: Any) -> Any:
        """``DensityGrid.eval`` at the points ``p`` (V64): F64, 0 outside the box."""
        dr, I32 = self.dr, self.I32
        inside = None
        a, b, f = [], [], []
        for k in range(3):
            u = (p[k] - self.lo[k]) / self._opaque(self.extent[k]) * self.res[k] - 0.5
            base = dr.floor(u)
            f.append(u - base)
            a.append(dr.clip(I32(base), 0, self.res[k] - 1))
            b.append(dr.clip(I32(base) + 1, 0, self.res[k] - 1))
            within = (p[k] >= self.lo[k]) & (p[k] <= self.hi[k])
            inside = within if inside is None else inside & within
        nx, ny = self.res[0], self.res[1]
        out = None
        for z, wz in ((a[2], 1.0 - f[2]), (b[2], f[2])):
            for y, wy in ((a[1], 1.0 - f[1]), (b[1], f[1])):
                row = (z * ny + y) * nx
                term = wz * wy * ((1.0 - f[0]) * self._value(row + a[0]) + f[0] * self._value(row + b[0]))
                out = term if out is None else out + term
        return dr.select(inside, out, 0.0)

    def _opaque(self, value: float) -> Any:
        """``value`` as an opaque F64: Dr.Jit turns a division by a literal into a multiplication
        by its reciprocal, which rounds differently from numpy's division."""
        return self.dr.opaque(self.F64, value)

    def _value(self, index: Any) -> Any:
        return self.dr.gather(self.F64, self.values, self.U32(index))

    def _clamped(self, o: Any, d: Any, s: Any) -> Any:
        """ρ at o + s·d clamped into the box (a piece's end: rounding cannot put it outside)."""
        dr = self.dr
        return self.eval(self.V64(*(dr.clip(o[k] + d[k] * s, self.lo[k], self.hi[k]) for k in range(3))))

    # --- free flights -------------------------------------------------------------------
    def delta_track(self, o: Any, d: Any, t_max: Any, rate: float, seed: Any, photon: Any, step: Any) -> Any:
        """``scenes.tracking.delta_track``: the first real collision on o + t·d, t < ``t_max``
        (F64; a lane with t_max < 0 tracks nothing), at rate ρ(x)·``rate``: F64, −1 where none."""
        dr, F64, U32, I32 = self.dr, self.F64, self.U32, self.I32
        t_in, t_end = self._box_interval(o, d)
        t_end = dr.minimum(t_end, t_max)
        active = (t_in < t_end) & (rate > 0)
        cell, t_next, t_step, stride = [], [], [], []
        for k in range(3):
            inv = 1.0 / d[k]
            start = (o[k] + d[k] * t_in - self.lo[k]) / self._opaque(self.cell_size[k])
            c = dr.clip(I32(dr.floor(start)), 0, self.m_res[k] - 1)
            moving = d[k] != 0
            plane = self.lo[k] + F64(dr.select(d[k] >= 0, c + 1, c)) * self.cell_size[k]
            cell.append(c)
            t_next.append(dr.select(moving, (plane - o[k]) * dr.select(moving, inv, 0.0), dr.inf))
            t_step.append(dr.select(moving, dr.abs(self.cell_size[k] * dr.select(moving, inv, 0.0)), dr.inf))
            stride.append(dr.select(d[k] > 0, I32(1), dr.select(d[k] < 0, I32(-1), I32(0))))
        budget = -dr.log(1.0 - F64(self.uniform(seed, photon, step, U32(TRACKING_DIM))))
        out, tentative = dr.full(F64, -1.0, dr.width(t_in)), dr.zeros(U32, dr.width(t_in))
        mx, my, mz = self.m_res

        def body(active, t, budget, tentative, out, cx, cy, cz, nx, ny, nz):
            t_exit = dr.minimum(dr.minimum(dr.minimum(nx, ny), nz), t_end)
            mu = F64(dr.gather(self.F32, self.majorants, U32((cz * my + cy) * mx + cx), active)) * rate
            here = mu * (t_exit - t) > budget  # a tentative collision in this cell
            t_c = t + budget / mu
            xi = F64(self.uniform(seed, photon, step, U32(TRACKING_DIM) + 2 * tentative + 1))
            point = self.V64(*(o[k] + d[k] * t_c for k in range(3)))
            real = here & (xi * mu < self.eval(point) * rate)
            out = dr.select(active & real, t_c, out)
            tentative_c = tentative + 1
            budget_c = -dr.log(1.0 - F64(self.uniform(seed, photon, step, U32(TRACKING_DIM) + 2 * tentative_c)))
            # no collision here: on to the next cell (numpy's argmin: the first smallest)
            along_x = (nx <= ny) & (nx <= nz)
            along_y = ~along_x & (ny <= nz)
            along_z = ~along_x & ~along_y
            cx_m, cy_m, cz_m = (dr.select(along, c + s, c) for along, c, s in
                                ((along_x, cx, stride[0]), (along_y, cy, stride[1]), (along_z, cz, stride[2])))
            nx_m, ny_m, nz_m = (dr.select(along, n + s, n) for along, n, s in
                                ((along_x, nx, t_step[0]), (along_y, ny, t_step[1]), (along_z, nz, t_step[2])))
            left = ((t_exit >= t_end) | (cx_m < 0) | (cx_m >= mx) | (cy_m < 0) | (cy_m >= my)
                    | (cz_m < 0) | (cz_m >= mz))
            moved = active & ~here
            collided = active & here
            budget = dr.select(collided, budget_c, dr.select(moved, budget - mu * (t_exit - t), budget))
            t = dr.select(collided, t_c, dr.select(moved, t_exit, t))
            tentative = dr.select(collided, tentative_c, tentative)
            cx, cy, cz = (dr.select(moved, new, old) for new, old in ((cx_m, cx), (cy_m, cy), (cz_m, cz)))
            nx, ny, nz = (dr.select(moved, new, old) for new, old in ((nx_m, nx), (ny_m, ny), (nz_m, nz)))
            active = dr.select(collided, ~real & (tentative_c < MAX_TENTATIVE), active & ~left)
            return active, t, budget, tentative, out, cx, cy, cz, nx, ny, nz

        state = dr.while_loop((active, t_in, budget, tentative, out, *cell, *t_next),
                              lambda active, *_: active, body)
        return state[4]

    def _box_interval(self, o: Any, d: Any) -> tuple:
        """``scenes.tracking._box_interval``: the entry (≥ 0) and exit distances with the box."""
        dr = self.dr
        near = far = None
        for k in range(3):
            inv = 1.0 / d[k]
            ta, tb = (self.lo[k] - o[k]) * inv, (self.hi[k] - o[k]) * inv
            ta, tb = dr.select(dr.isnan(ta), -dr.inf, ta), dr.select(dr.isnan(tb), dr.inf, tb)
            lo, hi = dr.minimum(ta, tb), dr.maximum(ta, tb)
            near = lo if near is None else dr.maximum(near, lo)
            far = hi if far is None else dr.minimum(far, hi)
        return dr.maximum(near, 0.0), far

    # --- optical depth ------------------------------------------------------------------
    def optical_depth(self, o: Any, d: Any, length: Any) -> Any:
        """``scenes.tracking.optical_depth``: ∫₀^length ρ(o + s·d) ds (d unit), F64 ≥ 0."""
        dr, F64 = self.dr, self.F64
        length = dr.maximum(length, 0.0)
        index, last, step, faces = [], [], [], []
        for k in range(3):
            a, b = o[k], o[k] + d[k] * length
            n = self.res[k]
            first = dr.clip(dr.ceil((dr.minimum(a, b) - self.lo[k]) / self._opaque(self.h[k]) - 0.5), 0, n - 1)
            final = dr.clip(dr.floor((dr.maximum(a, b) - self.lo[k]) / self._opaque(self.h[k]) - 0.5), -1, n - 1)
            forward = d[k] >= 0  # the planes first … final, visited in the order the ray meets them
            start = dr.select(forward, first, final)
            # a plane at or behind the start (rounding) is no cut: numpy's 0 or a break < 0
            if_behind = self._plane(o, d, k, start) <= 0.0
            step.append(dr.select(forward, 1.0, -1.0))
            index.append(dr.select(if_behind, start + step[k], start))
            last.append((first, final))
            faces += [(self.lo[k] - a) / d[k], (self.hi[k] - a) / d[k]]

        def plane_at(k, i):
            first, final = last[k]
            within = (i >= first) & (i <= final)
            t = self._plane(o, d, k, i)
            return dr.select(within & dr.isfinite(t), t, dr.inf)

        def body(t, depth, ix, iy, iz):
            planes = [plane_at(0, ix), plane_at(1, iy), plane_at(2, iz)]
            t1 = length
            for value in planes + faces:
                t1 = dr.select(dr.isfinite(value) & (value > t) & (value < t1), value, t1)
            width = t1 - t
            mid = t + 0.5 * width
            centre = self.V64(*(o[k] + d[k] * mid for k in range(3)))
            inside = None
            for k in range(3):
                within = (centre[k] >= self.lo[k]) & (centre[k] <= self.hi[k])
                inside = within if inside is None else inside & within
            ends = self._clamped(o, d, t), self._clamped(o, d, t1)
            simpson = width / self._opaque(6.0) * (ends[0] + 4.0 * self.eval(centre) + ends[1])
            depth = dr.select(inside, depth + simpson, depth)
            ix, iy, iz = (dr.select(p <= t1, i + s, i) for p, i, s in zip(planes, (ix, iy, iz), step))
            return t1, depth, ix, iy, iz

        zero = dr.zeros(F64, dr.width(length))
        state = dr.while_loop((zero, zero, *index), lambda t, *_: t < length, body)
        return state[1]

    def _plane(self, o: Any, d: Any, k: int, i: Any) -> Any:
        """The distance along axis ``k`` to the plane through the centres of cells ``i``."""
        return (self.lo[k] + (i + 0.5) * self.h[k] - o[k]) / d[k]
