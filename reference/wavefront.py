"""The exact replay's steps in Dr.Jit: the photons' state stays on the device between
steps, and each step is one fused kernel around the ray cast.

``reference.replay`` traced a launch's photons with one numpy pass after another per
step (``oracle.advance``: the box exit, the random numbers, the oracle query's copies
in and out, the surface interaction), which held the replay to 0.07–0.16 of the
machine's ray-casting bound (``bench/exact_replay.py``). Here the same physics, in
the same float64 arithmetic and order of operations, runs as Dr.Jit arrays of the
oracle's Mitsuba variant (LLVM on the CPU, CUDA on a GPU); only each step's medium
collisions and, after the last step, the photons still alive come back to numpy.

Equal to ``oracle.advance`` to float32 rounding of what the records keep (a test
compares every built-in): add, multiply, divide and square root round alike in both;
Dr.Jit's ``exp`` differs from numpy's in the last bit of a float64 now and then,
below the records' float32; the free flight, where a float32 ``log`` of numpy and
of Dr.Jit differ in a quarter of the 2^24 possible draws, is read from a table of
numpy's own values (:func:`free_flight_table`).
"""

from __future__ import annotations

import sys
from functools import lru_cache
from typing import Any

import numpy as np

from volcaustics.scenes.formats import STATUS_COLLIDED, STATUS_LEFT_SCENE, STATUS_LOST, STATUS_SURFACE
from volcaustics.scenes.rng import FRESNEL_DIM, GOLDEN, PCG_INC, PCG_MULT, PCG_WORD, ROTATION_PHOTON

from .oracle import Oracle, ReplayConstants
from .wavefront_grid import GridWavefront


@lru_cache(maxsize=4)
def free_flight_table(sigma_bar: float) -> np.ndarray:
    """2^24 float32: the free-flight distance ``-log(1 - u) / sigma_bar`` for every
    u = k·2^-24 (``scenes.rng.uniform``'s grid), in numpy's float32 arithmetic as
    ``oracle.advance`` computes it, so both replays draw the very same distances."""
    u = np.arange(1 << 24, dtype=np.uint32).astype(np.float32) * np.float32(2.0**-24)
    return -np.log(np.float32(1.0) - u) / np.float32(sigma_bar)


class Wavefront:
    """The step kernel of one scene's exact replay on ``oracle``'s Mitsuba variant."""

    def __init__(self, c: ReplayConstants, oracle: Oracle):
        import drjit as dr

        mi = self.mi = oracle.mi
        m = sys.modules[mi.Float.__module__]
        self.dr, self.c, self.oracle = dr, c, oracle
        self.F64, self.V64, self.U32, self.I32, self.F32 = m.Float64, m.Array3f64, mi.UInt32, mi.Int32, mi.Float
        self.sigma_t = [float(x) for x in c.sigma_t]
        self.ior = self.F64(c.ior)                   # per object, the medium's last
        self.absorption = [self.F64(c.absorption[:, k]) for k in range(3)]
        self.shape_index = self.I32(oracle.shape_index.astype(np.int32))
        self.tracks = c.sigma_bar > 0 and not c.beams  # photons fly free in the medium
        self.free = self.F32(free_flight_table(c.sigma_bar)) if self.tracks and c.grid is None else None
        types = (dr, self.F64, self.V64, self.U32, self.I32, self.F32)
        # a density grid: delta tracking and exact optical depths on the device
        self.grid = GridWavefront(c.grid, types, self.uniform) if c.grid is not None else None

    # --- the counter-based random numbers (scenes.rng) ---------------------------------
    def _pcg(self, v):
        state = v * PCG_MULT + PCG_INC
        word = ((state >> ((state >> 28) + 4)) ^ state) * PCG_WORD
        return (word >> 22) ^ word

    def _hash(self, seed, photon, step, dim: int):
        return self._pcg(self._pcg(self._pcg(self._pcg(seed) + photon) + step) + dim)

    def uniform(self, seed: Any, photon: Any, step: int | Any, dim: int) -> Any:
        """``scenes.rng.uniform(seed, photon, step, dim)`` as Dr.Jit float32 (U32 seed and
        photon; ``step`` an int, or a U32 made opaque so one kernel serves every step)."""
        if isinstance(step, int):
            step = self.dr.opaque(self.U32, step)
        return self.F32(self._hash(seed, photon, step, dim) >> 8) * (2.0**-24)

    def fresnel_uniform(self, seed: Any, photon: Any, step: int | Any) -> Any:
        """``scenes.rng.fresnel_uniform(c.fresnel, seed, photon, step)`` as Dr.Jit float32:
        ``stratified``'s Weyl sequence for fresnel = stratified, else :meth:`uniform`."""
        if self.c.fresnel != "stratified":
            return self.uniform(seed, photon, step, FRESNEL_DIM)
        if isinstance(step, int):
            step = self.dr.opaque(self.U32, step)
        rotation = self._hash(seed, self.U32(ROTATION_PHOTON), step, FRESNEL_DIM)
        return self.F32((rotation + photon * self.U32(GOLDEN)) >> 8) * (2.0**-24)

    # --- Fresnel splitting (scenes.splitting) ---------------------------------------------
    def split_number(self, xi: Any, photon: Any, step: Any) -> Any:
        """``scenes.splitting.split_number``: ``xi`` (F64), or the forced choice's number of
        photon slot ``photon`` (U32) at interaction ``step`` (U32)."""
        splits = self.c.splits
        if not splits:
            return xi
        dr, U32 = self.dr, self.U32
        batch = photon // U32(self.c.slots)
        chain = step < dr.minimum(batch, U32(splits))
        off = (step == batch) & (batch < U32(splits))
        return dr.select(chain, 2.0, dr.select(off, -1.0, xi))

    def silent(self, photon: Any, step: int) -> Any:
        """``scenes.splitting.silent`` of photon slots ``photon`` (U32) at ``step``."""
        batch = photon // self.U32(max(self.c.slots, 1))
        return (batch < self.U32(self.c.splits)) & (self.U32(step) <= batch)

    # --- one step ---------------------------------------------------------------------
    def step(self, step: int, seed: Any, idx: Any, o: Any, d: Any, inside: Any, power: Any) -> dict:
        """``oracle.advance`` for the photons ``idx`` with ``seed`` (U32), at ``o`` going
        ``d`` (V64), ``inside`` (I32, −1 medium), ``power`` (V64): lazy arrays of the
        step's end, status, new power and the state after it."""
        dr, F64, V64 = self.dr, self.F64, self.V64
        step_u = dr.opaque(self.U32, step)  # one kernel for every step: the step is a value, not a constant
        span = self._box_exit(o, d)
        medium = inside < 0
        # free flight: through the grid by delta tracking, else from u(seed, photon, step, 0), numpy's own
        # float32 distances
        if self.grid is not None and self.tracks:
            tracked = self.grid.delta_track(o, d, dr.select(medium, span, -1.0), self.c.sigma_bar, seed, idx, step_u)
            max_len = dr.select(medium, dr.select(tracked >= 0.0, tracked, 2.0 * span + 1.0), span)
        elif self.free is not None:
            k = self._hash(seed, idx, step_u, 0) >> 8
            max_len = dr.select(medium, F64(dr.gather(self.F32, self.free, k)), span)
        else:
            max_len = F64(span)
        search = dr.minimum(max_len, span)
        hit, t, shape, n, n_geometric = self._first_hit(o, d, search)
        collides = medium & (max_len <= span) & (not self.c.beams)
        along = dr.select(hit, t, dr.select(collides, max_len, search))
        end = o + d * along
        # transmittance of the distance travelled (the medium's, or the glass's inside)
        travelled = dr.select(hit, t, dr.select(collides, max_len, 0.0))
        inside_at = self.U32(dr.select(medium, dr.width(self.ior) - 1, inside))
        if self.grid is None:
            new_power = V64(*(power[k] * dr.exp(-dr.select(medium, self.sigma_t[k],
                                                            dr.gather(F64, self.absorption[k], inside_at))
                                                * travelled) for k in range(3)))
        else:  # glass absorbs as always (the medium's row is 0); the medium through its grid
            depth = self.grid.optical_depth(o, d, dr.select(medium, travelled, 0.0))
            new_power = V64(*(power[k] * dr.exp(-dr.gather(F64, self.absorption[k], inside_at) * travelled)
                              * dr.select(medium, dr.exp(-self.sigma_t[k] * depth), 1.0) for k in range(3)))
        status = dr.select(hit, STATUS_SURFACE, dr.select(~medium, STATUS_LOST,
                                                          dr.select(collides, STATUS_COLLIDED, STATUS_LEFT_SCENE)))
        # the surface interaction where it hit (oracle.surface_interaction)
        xi = self.split_number(F64(self.fresnel_uniform(seed, idx, step_u)), idx, step_u)
        new_d, interacted_power, new_inside = self._interaction(d, new_power, n, n_geometric, shape, xi)
        return {"end": end, "along": along, "status": self.I32(status),
                "new_power": dr.select(hit, interacted_power, new_power),
                "new_d": dr.select(hit, new_d, d), "new_inside": dr.select(hit, new_inside, inside)}

    def _box_exit(self, o, d):
        """The distance along ``d`` from ``o`` (V64) to the medium box's exit
        (``scenes.bounds.box_exit``)."""
        dr, c = self.dr, self.c
        span = None
        for k in range(3):
            inv = 1.0 / d[k]
            far = dr.maximum((float(c.lo[k]) - o[k]) * inv, (float(c.hi[k]) - o[k]) * inv)
            far = dr.select(dr.isnan(far), dr.inf, far)
            span = far if span is None else dr.minimum(span, far)
        return dr.maximum(span, 0.0)

    def _first_hit(self, o, d, search):
        """``oracle.first_hits`` on the segments o + t·d, t ≤ ``search`` (the same float32
        ray and epsilon): lazy (hit, t, shape, shading normal, geometric normal)."""
        dr, F32, F64, V64, mi = self.dr, self.F32, self.F64, self.V64, self.mi
        eps = self.oracle.epsilon
        origin = o + d * eps
        ray = mi.Ray3f(mi.Point3f(F32(origin[0]), F32(origin[1]), F32(origin[2])),
                       mi.Vector3f(F32(d[0]), F32(d[1]), F32(d[2])))
        ray.maxt = F32(dr.maximum(search - eps, 0.0))
        self.oracle.rays += dr.width(search)
        if self.oracle.segments is not None:
            self.oracle.segments.append(tuple(_numpy(v) for v in (ray.o, ray.d, ray.maxt)))
        si = self.oracle.mi_scene.ray_intersect(ray)
        hit = si.is_valid() & (search > eps)
        t = dr.select(hit, F64(si.t) + eps, 0.0)
        sid = dr.clip(self.I32(dr.reinterpret_array(self.U32, si.shape)), 0, dr.width(self.shape_index) - 1)
        shape = dr.select(hit, dr.gather(self.I32, self.shape_index, self.U32(sid)), -1)
        return hit, t, shape, V64(si.sh_frame.n), V64(si.n)

    def light_hits(self, light: np.ndarray, direction: np.ndarray, power: np.ndarray, photon: np.ndarray) -> tuple:
        """Rays from the point ``light`` along ``direction`` (numpy N×3 float64, with
        their ``power`` N×3 and ``photon`` N) to their exact first surface, as
        ``reference.replay``'s seed-free emission: rays without power are not cast.
        Returns (the input positions of the rays that hit, numpy, in order; and for
        those, on the device: photon, start, d, carried (the power times the medium's
        transmittance to the hit), normal, geometric_normal, shape; None when none
        hit)."""
        dr, V64, U32 = self.dr, self.V64, self.U32
        if len(direction) == 0:  # Dr.Jit refuses size-0 arrays beside literals: nothing to cast
            return np.zeros(0, np.int64), None
        power = _vector(V64, power)
        lit = dr.compress((power[0] > 0) | (power[1] > 0) | (power[2] > 0))
        if dr.width(lit) == 0:  # no ray with power: nothing to cast (a size-0 ray is not one)
            return np.zeros(0, np.int64), None
        d, power = dr.gather(V64, _vector(V64, direction), lit), dr.gather(V64, power, lit)
        o = V64(*(dr.full(self.F64, float(x), dr.width(lit)) for x in light))
        hit, t, shape, n, n_geometric = self._first_hit(o, d, self._box_exit(o, d))
        dr.eval(hit, t, shape, n, n_geometric)
        at = dr.compress(hit)
        if dr.width(at) == 0:
            return np.zeros(0, np.int64), None
        t, d, carried = dr.gather(self.F64, t, at), dr.gather(V64, d, at), dr.gather(V64, power, at)
        light_at = V64(*(dr.full(self.F64, float(x), dr.width(at)) for x in light))
        depth = t if self.grid is None else self.grid.optical_depth(light_at, d, t)
        carried = V64(*(carried[k] * dr.exp(-self.sigma_t[k] * depth) for k in range(3)))
        where = dr.gather(U32, lit, at)
        hits = {"photon": dr.gather(U32, U32(photon.astype(np.uint32)), where),
                "start": V64(*(float(light[k]) + d[k] * t for k in range(3))), "d": d, "carried": carried,
                "normal": dr.gather(V64, n, at), "geometric_normal": dr.gather(V64, n_geometric, at),
                "shape": dr.gather(self.I32, shape, at)}
        dr.eval(hits, where)
        return where.numpy().astype(np.int64), hits

    def _interaction(self, d, power, n, n_geometric, material, xi):
        """``oracle.surface_interaction`` (its operations in its order): the new
        direction, power and inside."""
        dr, F64, V64, c = self.dr, self.F64, self.V64, self.c
        from_outside = _dot(d, n) <= 0
        n = dr.select(from_outside, n, -n)
        ior = dr.gather(F64, self.ior, self.U32(dr.maximum(material, 0)))
        eta = dr.select(from_outside, ior, 1.0 / ior)
        cos_i = -_dot(d, n)
        sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
        cos_t = dr.sqrt(dr.maximum(1.0 - sin2_t, 0.0))
        r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
        r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
        tir = sin2_t >= 1.0
        R = dr.select(tir, 1.0, 0.5 * (r_s * r_s + r_p * r_p))
        refracted = V64(*(d[k] / eta + (cos_i / eta - cos_t) * n[k] for k in range(3)))
        length = dr.maximum(dr.sqrt(_dot(refracted, refracted)), 1e-300)
        refracted = V64(*(refracted[k] / length for k in range(3)))
        twice = 2.0 * _dot(d, n)
        reflected = V64(*(d[k] - twice * n[k] for k in range(3)))
        # a split's forced choices (scenes.splitting.FORCED_NUMBER): reflect at R, refract at 1 − R (none under TIR)
        forced_reflect, forced_refract = xi < 0.0, xi > 1.0
        free = ~(forced_reflect | forced_refract)
        reflect = tir | forced_reflect | ((free & (xi < R)) if c.stochastic else False)
        if not c.stochastic:
            power = dr.select(tir | ~free, power, V64(*(power[k] * (1.0 - R) for k in range(3))))
        factor = dr.select(forced_reflect, R, dr.select(forced_refract, dr.select(tir, 0.0, 1.0 - R), 1.0))
        power = dr.select(free, power, V64(*(power[k] * factor for k in range(3))))
        new_d = dr.select(reflect, reflected, refracted)
        new_inside = dr.select(_dot(new_d, n_geometric) < 0, material, -1)
        return new_d, power, new_inside

    # --- a launch ---------------------------------------------------------------------
    def trace(self, steps: int, group: np.ndarray, seed: np.ndarray, idx: np.ndarray, o: np.ndarray, d: np.ndarray,
              inside: np.ndarray, power: np.ndarray) -> tuple:
        """Replay the photons (numpy: group, seed uint32, idx int64, o, d N×3 float64,
        inside int64, power N×3 float64) ``steps`` steps: (collisions, alive) where
        collisions holds per step the medium collisions' group, photon, step, end,
        direction and power (numpy, the photons' order) and alive the (group, power)
        of those still travelling after the last step."""
        V64, U32, I32 = self.V64, self.U32, self.I32
        if len(idx) == 0:  # no photon: no step (Dr.Jit refuses size-0 arrays beside literals)
            return [], (np.zeros(0, np.int64), np.zeros((0, 3)))
        state = {"group": U32(group.astype(np.uint32)), "seed": U32(seed.astype(np.uint32)),
                 "idx": U32(idx.astype(np.uint32)), "o": _vector(V64, o), "d": _vector(V64, d),
                 "inside": I32(inside.astype(np.int32)),
                 "power": _vector(V64, power)}
        return self.run(steps, state)

    def emitted(self, hits: dict, take: np.ndarray, group: np.ndarray, seed: np.ndarray) -> tuple:
        """The state that ``reference.replay.exact_emission`` records and
        ``oracle.emission_state`` reads back, made on the device: photons ``take`` of
        ``hits`` (:meth:`light_hits`: per photon its photon, start, direction d, carried
        power, normal, geometric_normal and shape at the first surface) of replay ``group``
        with ``seed``, after the surface's interaction with the choice u(seed, photon,
        0, 1); start, direction and power rounded to the records' float32 and the
        direction renormalised, as the records carry them. Returns (state for
        :meth:`run`, the float32 power of each photon as numpy)."""
        dr, F64, V64, U32, I32, F32 = self.dr, self.F64, self.V64, self.U32, self.I32, self.F32
        index = U32(take.astype(np.uint32))
        at = {name: dr.gather(V64, hits[name], index)
              for name in ("start", "d", "carried", "normal", "geometric_normal")}
        photon = dr.gather(U32, hits["photon"], index)
        shape = dr.gather(I32, hits["shape"], index)
        seed_u = U32(seed.astype(np.uint32))
        xi = self.split_number(F64(self.fresnel_uniform(seed_u, photon, 0)), photon, self.dr.opaque(self.U32, 0))
        new_d, power, inside = self._interaction(at["d"], at["carried"], at["normal"], at["geometric_normal"], shape,
                                                 xi)
        d = V64(F32(new_d[0]), F32(new_d[1]), F32(new_d[2]))   # the record's float32, renormalised
        length = dr.sqrt(_dot(d, d))
        power32 = V64(F32(power[0]), F32(power[1]), F32(power[2]))
        state = {"group": U32(group.astype(np.uint32)), "seed": seed_u, "idx": photon,
                 "o": V64(F32(at["start"][0]), F32(at["start"][1]), F32(at["start"][2])),
                 "d": V64(d[0] / length, d[1] / length, d[2] / length), "inside": I32(inside), "power": power32}
        dr.eval(state)
        return state, _numpy(power32)

    def run(self, steps: int, state: dict) -> tuple:
        """:meth:`trace` from a state on the device (Dr.Jit arrays: group, seed, idx
        U32; o, d, power V64; inside I32)."""
        dr, V64, U32, I32 = self.dr, self.V64, self.U32, self.I32
        kept = []
        for step in range(1, steps + 1):
            s = self.step(step, state["seed"], state["idx"], state["o"], state["d"], state["inside"], state["power"])
            collided = s["status"] == STATUS_COLLIDED
            alive = (s["status"] == STATUS_SURFACE) | collided
            # what is splatted: the medium collisions, or (beams) the segments in the medium
            splatted = ((state["inside"] < 0) & (alive | (s["status"] == STATUS_LEFT_SCENE)) if self.c.beams
                        else collided)
            if self.c.splits:  # a split batch's share of another's segments is not splatted
                splatted = splatted & ~self.silent(state["idx"], step)
            dr.eval(s, collided, alive, splatted)
            at = dr.compress(splatted)
            if dr.width(at):
                row = {"group": dr.gather(U32, state["group"], at), "photon": dr.gather(U32, state["idx"], at),
                       "direction": dr.gather(V64, state["d"], at)}
                if self.c.beams:  # a beam: where the segment starts, its length, the power there
                    row.update(start=dr.gather(V64, state["o"], at), length=dr.gather(self.F64, s["along"], at),
                               power=dr.gather(V64, state["power"], at))
                else:
                    row.update(end=dr.gather(V64, s["end"], at), power=dr.gather(V64, s["new_power"], at))
                dr.eval(row)
                kept.append({"step": step, **{name: _numpy(value) for name, value in row.items()}})
            on = dr.compress(alive)
            state = {"group": dr.gather(U32, state["group"], on), "seed": dr.gather(U32, state["seed"], on),
                     "idx": dr.gather(U32, state["idx"], on), "o": dr.gather(V64, s["end"], on),
                     "d": dr.gather(V64, s["new_d"], on), "inside": dr.gather(I32, s["new_inside"], on),
                     "power": dr.gather(V64, s["new_power"], on)}
            dr.eval(state)
            if dr.width(on) == 0:
                break
        return kept, (_numpy(state["group"]).astype(np.int64), _numpy(state["power"]))


def _dot(a, b):
    """a·b summed as numpy's einsum and norm do: (x + y) + z, no fused multiply-add."""
    return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]


def _vector(kind, array: np.ndarray):
    """An N×3 numpy array as a Dr.Jit 3-vector of ``kind``: uploaded as it lies and
    gathered by component on the device (a transposed copy in numpy took 15× longer)."""
    import drjit as dr

    flat = dr.value_t(kind)(np.ascontiguousarray(array, np.float64).reshape(-1))
    index = dr.arange(dr.uint32_array_t(flat), len(array)) * 3
    return kind(*(dr.gather(type(flat), flat, index + k) for k in range(3)))


def _numpy(value) -> np.ndarray:
    """A Dr.Jit array as numpy: N×3 for a 3-vector, N otherwise."""
    array = value.numpy()
    return array.T if array.ndim == 2 else array
