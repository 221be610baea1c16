"""Exact intersections for the approximation's segments, and an exact photon tracer.

* :class:`Oracle`: exact first hit of arbitrary segments (start, direction, max
  length → hit flag, t, shading normal, geometric normal, specular object index)
  against the scene's specular objects — the geometry the approximation's light
  maps hold — with Mitsuba's ``scene.ray_intersect``.
* :func:`exact_photon_records`: replays the approximation's photons from their
  emission state with exact intersections and the very same random numbers
  (``scenes.rng``: free flight from u(seed, photon, step, 0), Fresnel choice from
  u(seed, photon, step, 1)), producing per-step records in the approximation's
  format (``scenes.formats.RECORD_DTYPE``), so the two can be compared segment by
  segment. The physics mirrors ``approx/shaders/trace/trace.comp.glsl``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np

from volcaustics.scenes.bounds import box_exit, medium_bounds
from volcaustics.scenes.formats import (
    FLAG_REFLECTED,
    FLAG_TIR,
    RECORD_DTYPE,
    STATUS_COLLIDED,
    STATUS_LEFT_SCENE,
    STATUS_LOST,
    STATUS_SURFACE,
)
from volcaustics.scenes.medium_grid import density_grid
from volcaustics.scenes.rng import FRESNEL_MODES, fresnel_uniform, stochastic_fresnel, uniform
from volcaustics.scenes.splitting import split_number
from volcaustics.scenes.tracking import delta_track, optical_depth

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from volcaustics.scenes.model import Scene


class Oracle:
    """Exact segment queries against one scene's specular objects."""

    def __init__(self, scene):
        from .mi_setup import mitsuba
        from .render.export import mesh_file

        mi = self.mi = mitsuba()
        import drjit as dr

        d = {"type": "scene"}
        for i, obj in enumerate(scene.specular):
            d[f"specular_{i}"] = {"type": "ply", "filename": mesh_file(obj.mesh.load()),
                                  "face_normals": False}
        self.mi_scene = mi.load_dict(d, optimize=False)  # merging would drop the ids the table reads
        table = {}
        for shape in self.mi_scene.shapes():
            table[int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0])] = int(shape.id().split("_")[1])
        self.shape_index = np.full(max(table, default=0) + 1, -1, np.int64)
        for sid, i in table.items():
            self.shape_index[sid] = i
        lo, hi = medium_bounds(scene)
        self.epsilon = 1e-6 * float(np.linalg.norm(hi - lo))
        self.rays = 0  # segments queried so far (bench/exact_replay.py: throughput)
        self.segments = None  # a list: every query's float32 rays (origin, direction, maxt), for the same bench

    def first_hits(self, starts: ArrayLike, directions: ArrayLike, max_lengths: ArrayLike) -> dict:
        """Exact first hits on segments start + t·direction, t in (0, max_length].

        Parameters: starts, directions N×3 (directions unit), max_lengths N; metres.
        Returns hit (N bool), t (N float64, nan without hit), normal (N×3 shading
        normal, nan), geometric_normal (N×3), shape (N int, -1 without hit).
        """
        import drjit as dr

        mi = self.mi
        o = np.asarray(starts, np.float64).reshape(-1, 3)
        d = np.asarray(directions, np.float64).reshape(-1, 3)
        L = np.asarray(max_lengths, np.float64).reshape(-1)
        if len(o) == 0:
            return {"hit": np.zeros(0, bool), "t": np.zeros(0), "normal": np.zeros((0, 3)),
                    "geometric_normal": np.zeros((0, 3)), "shape": np.zeros(0, np.int64)}
        eps = self.epsilon
        self.rays += len(o)
        ray = mi.Ray3f(mi.Point3f(*(o + d * eps).T.astype(np.float32)), mi.Vector3f(*d.T.astype(np.float32)))
        ray.maxt = mi.Float(np.maximum(L - eps, 0.0).astype(np.float32))
        if self.segments is not None:
            self.segments.append(((o + d * eps).astype(np.float32), d.astype(np.float32),
                                  np.maximum(L - eps, 0.0).astype(np.float32)))
        si = self.mi_scene.ray_intersect(ray)
        # every output in one kernel: each lazy value read on its own would launch (and trace) again
        valid = si.is_valid()
        sid: Any = dr.reinterpret_array(mi.UInt32, si.shape)  # Dr.Jit's stubs say object
        normal, geometric = si.sh_frame.n, si.n
        dr.eval(valid, si.t, sid, normal, geometric)
        hit = valid.numpy().astype(bool) & (L > eps)
        t = np.where(hit, si.t.numpy().astype(np.float64) + eps, np.nan)
        shape = np.where(hit, self.shape_index[np.clip(sid.numpy().astype(np.int64), 0, len(self.shape_index) - 1)],
                         -1)

        def vec(v):
            return np.stack([v.x.numpy(), v.y.numpy(), v.z.numpy()], axis=1).astype(np.float64)

        nan3 = np.full((len(o), 3), np.nan)
        return {"hit": hit, "t": t, "normal": np.where(hit[:, None], vec(normal), nan3),
                "geometric_normal": np.where(hit[:, None], vec(geometric), nan3), "shape": shape}


def fresnel_dielectric(cos_i: np.ndarray, eta: np.ndarray | float) -> np.ndarray:
    """Unpolarised Fresnel reflectance (numpy twin of common/optics.glsl), 1 under TIR."""
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(sin2_t >= 1.0, 1.0, 0.5 * (r_s * r_s + r_p * r_p))


def surface_interaction(d: np.ndarray, power: np.ndarray, n: np.ndarray, n_geometric: np.ndarray,
                        hit_material: np.ndarray, xi: np.ndarray, ior: np.ndarray,
                        stochastic: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Vectorised twin of common/interaction.glsl; returns (d, power, inside, flags).

    n: outward shading normals, n_geometric: outward geometric normals (N×3). As
    Mitsuba's dielectric, the incident side and eta come from the shading normal;
    inside afterwards follows the one rule of docs/conventions.md: below the geometric surface is
    inside the object hit. :func:`interaction_geometry`, then :func:`interaction_choice`."""
    return interaction_choice(interaction_geometry(d, n, hit_material, ior), power, n_geometric, hit_material, xi,
                              stochastic)


def interaction_geometry(d: np.ndarray, n: np.ndarray, hit_material: np.ndarray, ior: np.ndarray) -> dict:
    """What a surface interaction is before its Fresnel choice (no random number): the
    reflected and refracted directions, the reflectance R and total internal reflection
    (``tir``), for directions ``d`` at outward shading normals ``n`` (N×3)."""
    from_outside = np.einsum("ij,ij->i", d, n) <= 0
    n = np.where(from_outside[:, None], n, -n)
    eta = np.where(from_outside, ior[hit_material], 1.0 / ior[hit_material])
    cos_i = -np.einsum("ij,ij->i", d, n)
    R = fresnel_dielectric(cos_i, eta)
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    refracted = d / eta[:, None] + (cos_i / eta - cos_t)[:, None] * n
    refracted /= np.maximum(np.linalg.norm(refracted, axis=1, keepdims=True), 1e-300)
    reflected = d - 2.0 * np.einsum("ij,ij->i", d, n)[:, None] * n
    return {"reflected": reflected, "refracted": refracted, "R": R, "tir": tir}


def interaction_choice(geometry: dict, power: np.ndarray, n_geometric: np.ndarray, hit_material: np.ndarray,
                       xi: np.ndarray, stochastic: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The interaction's Fresnel choice with ``xi`` (N) on :func:`interaction_geometry`'s
    ``geometry``: (d, power, inside, flags) as :func:`surface_interaction`; ``xi`` below 0
    or above 1 is a split's forced choice (``scenes.splitting``), whatever ``stochastic``."""
    tir, R = geometry["tir"], geometry["R"]
    # a split's forced choices (scenes.splitting.FORCED_NUMBER): reflect at R, refract at 1 − R (none under TIR)
    forced_reflect, forced_refract = xi < 0, xi > 1
    free = ~(forced_reflect | forced_refract)
    reflect = tir | forced_reflect | (stochastic & free & (xi < R))
    if not stochastic:
        power = np.where((tir | ~free)[:, None], power, power * (1.0 - R)[:, None])
    power = np.where(forced_reflect[:, None], power * R[:, None],
                     np.where(forced_refract[:, None], power * np.where(tir, 0.0, 1.0 - R)[:, None], power))
    new_d = np.where(reflect[:, None], geometry["reflected"], geometry["refracted"])
    new_inside = np.where(np.einsum("ij,ij->i", new_d, n_geometric) < 0, hit_material, -1)
    flags = np.where(reflect, FLAG_REFLECTED, 0) | np.where(tir, FLAG_TIR, 0)
    return new_d, power, new_inside, flags


class ReplayConstants:
    """What every step of an exact replay of ``scene`` reads: the medium's box, sigma_t
    and the GPU tracer's float32 sigma_bar, each material's IOR and interior absorption
    (the last row: the medium's), the Fresnel mode and whether photons fly free in the
    medium (points) or run to the next surface (``beams``: splat = beams, no free flight)."""

    def __init__(self, scene, fresnel: str, *, beams: bool = False, splits: int = 0, slots: int = 0):
        self.lo, self.hi = medium_bounds(scene)
        self.sigma_t = np.asarray(scene.medium.sigma_t, np.float64)
        self.sigma_bar = float(np.float32(scene.medium.sigma_bar))  # the GPU tracer's float32 uniform
        self.ior = np.asarray([o.ior for o in scene.specular] + [1.0], np.float64)
        self.absorption = np.asarray([o.absorption for o in scene.specular] + [(0.0, 0.0, 0.0)], np.float64)
        if fresnel not in FRESNEL_MODES:
            raise ValueError(f"fresnel {fresnel!r}: expected one of {', '.join(FRESNEL_MODES)}")
        self.fresnel = fresnel
        self.stochastic = stochastic_fresnel(fresnel)
        self.beams = beams
        self.splits, self.slots = splits, slots  # fresnel_splits and a batch's photon slots (scenes.splitting)
        self.grid = density_grid(scene)  # a heterogeneous medium's density (None: homogeneous)

    def transmittance(self, o: np.ndarray, d: np.ndarray, length: np.ndarray) -> np.ndarray:
        """The medium's transmittance over o + s·d, s < ``length`` (N×3): exp(−σt·length),
        or exp(−σt·∫ρ) through the density grid (``scenes.tracking.optical_depth``: exact)."""
        depth = length if self.grid is None else optical_depth(self.grid, o, d, length)
        return np.exp(-self.sigma_t[None, :] * depth[:, None])


def advance(c: ReplayConstants, oracle: Oracle, step: int, seed: int | np.ndarray, idx: np.ndarray, o: np.ndarray,
            d: np.ndarray, inside: np.ndarray, power: np.ndarray) -> dict:
    """One interaction step of photons ``idx`` (emission texels) at ``o`` going ``d``
    (N×3 float64, unit), ``inside`` (object index, −1 medium), ``power`` (N×3 W): free
    flight from u(seed, photon, step, 0), the exact first hit, transmittance, and at a
    hit the surface interaction (Fresnel choice from ``scenes.rng.fresnel_uniform``).
    ``seed``: one seed, or one per photon (N uint32). Returns the step's segment
    (max_len, search, q: the oracle's answer), where it ended (end, how far it went:
    along, status, flags, new_power) and the state after it (new_d, new_inside)."""
    n = len(idx)
    span = box_exit(o, d, c.lo, c.hi)
    max_len = span.copy()
    medium = inside < 0
    if c.sigma_bar > 0 and not c.beams and c.grid is not None:  # the GPU's delta tracking, its numbers
        seeds = np.broadcast_to(np.asarray(seed, np.uint32), (n,))[medium]
        tracked = delta_track(c.grid, o[medium], d[medium], span[medium], c.sigma_bar, seeds,
                              idx[medium].astype(np.uint32), step)
        max_len[medium] = np.where(tracked >= 0.0, tracked, 2.0 * span[medium] + 1.0)
    elif c.sigma_bar > 0 and not c.beams:
        u = uniform(seed, idx.astype(np.uint32), step, 0).astype(np.float32)
        free = (-np.log(np.float32(1.0) - u) / np.float32(c.sigma_bar)).astype(np.float64)
        max_len = np.where(medium, free, span)
    search = np.minimum(max_len, span)
    q = oracle.first_hits(o, d, search)
    hit = q["hit"]
    t = np.where(hit, q["t"], 0.0)
    status = np.full(n, STATUS_LEFT_SCENE, np.int64)
    flags = np.zeros(n, np.int64)
    collides = medium & (max_len <= span) & (not c.beams)
    along = np.where(hit, t, np.where(collides, max_len, search))  # how far the photon went
    end = o + d * along[:, None]
    # transmittance of the distance travelled
    coeff = np.where(medium[:, None], c.sigma_t[None, :], c.absorption[np.where(medium, -1, inside)])
    travelled = np.where(hit, t, np.where(collides, max_len, 0.0))
    if c.grid is None:
        new_power = power * np.exp(-coeff * travelled[:, None])
    else:  # glass absorbs as always; the medium through its grid
        new_power = power * np.exp(-c.absorption[np.where(medium, -1, inside)] * travelled[:, None])
        new_power[medium] *= c.transmittance(o[medium], d[medium], travelled[medium])
    status[hit] = STATUS_SURFACE
    status[~hit & ~medium] = STATUS_LOST
    status[~hit & collides] = STATUS_COLLIDED
    new_d, new_inside = d.copy(), inside.copy()
    if hit.any():
        seed_hit = cast(np.ndarray, seed)[hit] if np.ndim(seed) else seed
        xi = split_number(fresnel_uniform(c.fresnel, seed_hit, idx[hit].astype(np.uint32), step).astype(np.float64),
                          idx[hit], step, c.splits, c.slots)
        dd, pp, ii, ff = surface_interaction(d[hit], new_power[hit], q["normal"][hit], q["geometric_normal"][hit],
                                             q["shape"][hit], xi, c.ior, c.stochastic)
        new_d[hit], new_power[hit], new_inside[hit], flags[hit] = dd, pp, ii, ff
    return {"max_len": max_len, "search": search, "q": q, "end": end, "along": along, "new_power": new_power,
            "status": status, "flags": flags, "new_d": new_d, "new_inside": new_inside}


def alive_after(status: np.ndarray) -> np.ndarray:
    """Photons still travelling after a step: at a surface, or collided and going on."""
    return (status == STATUS_SURFACE) | (status == STATUS_COLLIDED)


def exact_photon_records(scene: Scene, first_records: np.ndarray, *, steps: int, seed: int,
                         fresnel: str = "deterministic", oracle: Oracle | None = None, beams: bool = False,
                         splits: int = 0, slots: int = 0) -> list:
    """Replay photons from the approximation's step-1 records (their emission state:
    start, direction, inside, power_start) with exact intersections; returns one
    RECORD_DTYPE array per step (photons alive at that step). ``beams``: no free flight
    in the medium (splat = beams), as the tracer's; ``splits``, ``slots``: fresnel_splits
    and one batch's photon slots (``scenes.splitting``)."""
    oracle = oracle or Oracle(scene)
    c = ReplayConstants(scene, fresnel, beams=beams, splits=splits, slots=slots)
    idx, o, d, inside, power = emission_state(first_records)
    out = []
    for step in range(1, steps + 1):
        s = advance(c, oracle, step, seed, idx, o, d, inside, power)
        out.append(_step_record(step, idx, o, d, inside, power, **s))
        alive = alive_after(s["status"])
        idx, o, d, inside, power = idx[alive], s["end"][alive], s["new_d"][alive], s["new_inside"][alive], \
            s["new_power"][alive]
        if len(idx) == 0:
            break
    return out


def emission_state(first_records: np.ndarray) -> tuple:
    """(photon index, start, unit direction, inside, power) of step-1 records, in the
    replay's float64."""
    d = first_records["direction"].astype(np.float64)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return (first_records["photon"].astype(np.int64), first_records["start"].astype(np.float64), d,
            first_records["inside"].astype(np.int64), first_records["power_start"].astype(np.float64))


def _step_record(step, idx, o, d, inside, power, *, max_len, search, q, end, new_power, status, flags, **_):
    """One step's RECORD_DTYPE rows: the segment of each photon alive at its start (idx,
    start o, direction d, inside, power) and what the step made of it (``q``: the
    oracle's first hits)."""
    hit = q["hit"]
    rec = np.zeros(len(idx), RECORD_DTYPE)
    rec["photon"], rec["step"] = idx, step
    rec["start"], rec["direction"] = o, d
    rec["max_length"], rec["search_length"] = max_len, search
    rec["t"], rec["hit"] = np.where(hit, q["t"], np.nan), hit
    rec["map"] = -1
    rec["normal"] = q["normal"]
    rec["material"] = q["shape"]
    rec["inside"] = inside
    rec["end"] = end
    rec["power_start"], rec["power"] = power, new_power
    rec["status"], rec["flags"] = status, flags
    return rec
