"""The exact replay as a wavefront: many replays traced together.

The decomposition's E images replay every emission texel of every seed several times
(sub-photons, ``experiment.exact_images``). Replayed one by one, each step of
each replay is one oracle query and one round of numpy, so a point paid thousands of
small Dr.Jit launches and their fixed costs. Here every replay (a *group*: an emission
state and its seed) of a point is one set of photons, each photon carrying its group's
seed, and each step is one query for all of them (``oracle.advance``, the physics of
``exact_photon_records``, photon by photon the same numbers). Groups are packed into
launches of at most ``max_photons`` photons, which bounds memory.

Only what the E images read is kept: each medium collision (photon, step, end,
direction, power, as the records hold them), or with ``beams`` (splat = beams, no free
flight) each segment in the medium (photon, step, start, direction, length, power at
its start), and the power budgets.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from volcaustics.scenes.bounds import box_exit
from volcaustics.scenes.formats import RECORD_DTYPE, splatted_mask
from volcaustics.scenes.rng import fresnel_uniform
from volcaustics.scenes.splitting import silent, split_groups, split_number

from .oracle import (
    Oracle,
    ReplayConstants,
    advance,
    alive_after,
    emission_state,
    interaction_choice,
    interaction_geometry,
)

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

# Photons per launch: about 1 kB each of float64 state and temporaries at the widest step
MAX_PHOTONS = 1 << 21
COLLISION_DTYPE = np.dtype([(name, RECORD_DTYPE[name]) for name in ("photon", "step", "end", "direction", "power")])
# beams: a segment in the medium, from where it starts to the next surface or the medium's end
BEAM_ROW_DTYPE = np.dtype([(name, RECORD_DTYPE[name]) for name in ("photon", "step", "start", "direction")]
                          + [("length", "<f4"), ("power", "<f4", 3)])


class Rays(Protocol):
    """A set of rays leaving the light, as :func:`exact_emission` reads them (e.g.
    ``approx.emission.EmissionRays``): ``photon`` (N indices), ``direction`` (N×3 unit,
    from the light) and ``power`` (N×3 W)."""

    @property
    def photon(self) -> np.ndarray: ...

    @property
    def direction(self) -> np.ndarray: ...

    @property
    def power(self) -> np.ndarray: ...


@dataclass
class Collisions:
    """The medium collisions of one replay and its power budget.

    rows: COLLISION_DTYPE (beams: BEAM_ROW_DTYPE), in the order ``exact_photon_records``
        gives them (by step, then by photon order), with the records' float32 fields.
    emitted_power: RGB power (W) of the replayed photons at their start.
    alive_power: RGB power (W) still travelling after the last step.
    collided_power: steps×3, RGB power (W) of the collisions per step (beams: the
        power at their starts).
    photons: photons replayed.
    """

    rows: np.ndarray
    emitted_power: np.ndarray
    alive_power: np.ndarray
    collided_power: np.ndarray
    photons: int


def exact_emission(scene: Scene, groups: Iterable[tuple[Rays, int]], *, fresnel: str,
                   oracle: Oracle | None = None, max_photons: int = MAX_PHOTONS, splits: int = 0,
                   slots: int = 0) -> list:
    """Per group, the emission state (step-1 records: photon, start, direction, inside,
    power_start; RECORD_DTYPE) of photons leaving the light exactly: each ray from the
    light's position to its exact first specular surface, its power times the medium's
    transmittance to it, then that surface's interaction with the Fresnel choice
    ``scenes.rng.fresnel_uniform(fresnel, seed, photon, 0)``, as ``emit.comp.glsl`` does at
    the emission map's surface.
    Rays without power or without a hit emit nothing.

    groups : (rays, seed) pairs, ``rays`` with fields ``photon`` (N indices),
        ``direction`` (N×3 unit, from the light) and ``power`` (N×3 W), e.g.
        ``approx.emission.EmissionRays``; in launches of at most ``max_photons`` rays,
        groups that share one ``rays`` object traced once.
    splits, slots : fresnel_splits and one batch's photon slots: the rays' photons are
        slots of split batches (``scenes.splitting.split_groups``), forced at the first surface as
        ``scenes.splitting`` says.
    """
    oracle = oracle or Oracle(scene)
    c = ReplayConstants(scene, fresnel, splits=splits, slots=slots)
    light = np.asarray(scene.light.position, np.float64)

    def launch(part):
        traced = {}
        for key, (photon, start, d, carried, q) in _seed_free(part, c, oracle, light).items():
            traced[key] = (photon, start, carried, q, interaction_geometry(d, q["normal"], q["shape"], c.ior))
        out = []
        for rays, seed in part:
            photon, start, carried, q, geometry = traced[id(rays)]
            xi = split_number(fresnel_uniform(c.fresnel, seed, photon.astype(np.uint32), 0).astype(np.float64),
                              photon, 0, c.splits, c.slots)
            new_d, new_power, inside, _ = interaction_choice(geometry, carried, q["geometric_normal"], q["shape"], xi,
                                                             c.stochastic)
            first = np.zeros(len(photon), RECORD_DTYPE)
            first["photon"], first["step"] = photon, 1
            first["start"], first["direction"] = start, new_d
            first["inside"], first["power_start"] = inside, new_power
            out.append(first)
        return out

    return _packed(groups, lambda group: len(group[0].photon), launch, max_photons)


def _seed_free(part: list, c: ReplayConstants, oracle: Oracle, light: np.ndarray) -> dict:
    """What an exact emission holds before its Fresnel choice, once per set of rays of
    ``part`` ((rays, seed) pairs; A's grid serves every replay seed), keyed by the
    set's id: the photons with power that hit (photon), where (start), their direction
    d, their power carried there through the medium and the oracle's answer q: one
    query for all sets."""
    distinct = list({id(rays): rays for rays, _ in part}.values())
    lit = [np.flatnonzero(np.any(np.asarray(rays.power) > 0, axis=1)) for rays in distinct]
    d = np.concatenate([np.asarray(rays.direction, np.float64)[m] for rays, m in zip(distinct, lit)])
    origin = np.broadcast_to(light, d.shape)
    q = oracle.first_hits(origin, d, box_exit(origin, d, c.lo, c.hi))
    bounds = np.cumsum([0] + [len(m) for m in lit])
    out = {}
    for rays, m, lo, hi in zip(distinct, lit, bounds[:-1], bounds[1:]):
        hit = q["hit"][lo:hi]
        mine = {key: value[lo:hi][hit] for key, value in q.items()}
        direction, t = d[lo:hi][hit], mine["t"]
        carried = np.asarray(rays.power, np.float64)[m[hit]] * c.transmittance(np.broadcast_to(light, direction.shape),
                                                                               direction, t)
        out[id(rays)] = (np.asarray(rays.photon, np.int64)[m[hit]], light + direction * t[:, None], direction, carried,
                         mine)
    return out


def _packed(groups, size, launch, max_photons: int) -> list:
    """``launch`` over consecutive runs of ``groups`` of at most ``max_photons``
    (``size`` of each; a larger group is a run of its own), the results in order."""
    part: list
    out, part, total = [], [], 0
    for group in groups:
        if part and total + size(group) > max_photons:
            out += launch(part)
            part, total = [], 0
        part.append(group)
        total += size(group)
    return out + (launch(part) if part else [])


def exact_collisions(scene: Scene, groups: Iterable[tuple[np.ndarray, int]], *, steps: int, fresnel: str,
                     oracle: Oracle | None = None, max_photons: int = MAX_PHOTONS, engine: str = "drjit",
                     beams: bool = False, splits: int = 0, slots: int = 0) -> list:
    """Replay every group exactly for ``steps`` steps with ``fresnel``; one
    :class:`Collisions` per group, in order.

    Parameters
    ----------
    scene : the scene (``scenes.model.Scene``).
    groups : (first_records, seed) pairs: step-1 records (RECORD_DTYPE) to replay from
        and the seed of their random numbers.
    steps, fresnel : as ``reference.oracle.exact_photon_records``.
    max_photons : photons per launch (a group larger than this is one launch).
    engine : "drjit", the steps as Dr.Jit kernels on the oracle's variant
        (``reference.wavefront``), or "numpy", one numpy pass after another per step
        (``oracle.advance``: the physics' reference, which a test holds the other to).
    beams : no free flight; the segments in the medium are kept (BEAM_ROW_DTYPE).
    splits, slots : fresnel_splits and one batch's photon slots (``scenes.splitting``).
    """
    if engine not in ENGINES:
        raise ValueError(f"engine = {engine!r}: expected one of {', '.join(ENGINES)}")
    oracle = oracle or Oracle(scene)
    constants = ReplayConstants(scene, fresnel, beams=beams, splits=splits, slots=slots)
    tracer = (functools.partial(_numpy_steps, c=constants, oracle=oracle) if engine == "numpy"
              else _wavefront(constants, oracle).trace)
    return _packed(groups, lambda group: len(group[0]), lambda part: _launch(constants, oracle, part, steps, tracer),
                   max_photons)


ENGINES = ("drjit", "numpy")


def _wavefront(constants: ReplayConstants, oracle: Oracle):
    from .wavefront import Wavefront

    return Wavefront(constants, oracle)


def _launch(c: ReplayConstants, oracle: Oracle, groups: list, steps: int, tracer) -> list:
    """The groups of one launch: traced together (``tracer``), split back by group."""
    states = [emission_state(first) for first, _ in groups]
    idx, o, d, inside, power = (np.concatenate(parts) for parts in zip(*states))
    group, seed = _per_photon(groups, [len(first) for first, _ in groups])
    kept, alive = tracer(steps, group, seed, idx, o, d, inside, power)
    emitted = np.stack([first["power_start"].astype(np.float64).sum(axis=0) for first, _ in groups])
    return _collisions(kept, alive, steps, emitted, [len(first) for first, _ in groups], beams=c.beams)


def _per_photon(groups: list, counts: list) -> tuple:
    """(group index, seed uint32) of every photon of a launch: ``counts`` photons per
    (…, seed) pair of ``groups``, in order."""
    return (np.repeat(np.arange(len(groups)), counts),
            np.repeat(np.asarray([seed for _, seed in groups], np.uint32), counts))


def _collisions(kept: list, alive: tuple[np.ndarray, np.ndarray], steps: int, emitted: np.ndarray,
                photons: list, beams: bool = False) -> list:
    """One :class:`Collisions` per group of a launch from what its tracer returned:
    ``kept``, per step the collisions' group, photon, end, direction and power;
    ``alive``, the (group, power) of the photons alive after the last step; the
    groups' ``emitted`` power and ``photons``; ``beams``: the rows are beams."""
    groups = len(photons)
    alive_power = _group_sums(*alive, groups)
    collided_power = np.zeros((groups, steps, 3))
    dtype = BEAM_ROW_DTYPE if beams else COLLISION_DTYPE
    rows = np.zeros(sum(len(k["group"]) for k in kept), dtype)
    for name in dtype.names or ():  # the records' float32 and integer fields, as exact_photon_records writes
        if kept:
            rows[name] = np.concatenate([np.full(len(k["group"]), k["step"]) if name == "step" else k[name]
                                         for k in kept])
    owner = np.concatenate([k["group"] for k in kept]).astype(np.int64) if kept else np.zeros(0, np.int64)
    order = np.argsort(owner, kind="stable")  # by group, then by step, then by photon order: one replay's order
    rows, owner = rows[order], owner[order]
    bounds = np.searchsorted(owner, np.arange(groups + 1))
    _sum_by_group_and_step(collided_power, owner, rows)
    return [Collisions(rows=rows[bounds[g]:bounds[g + 1]], emitted_power=emitted[g], alive_power=alive_power[g],
                       collided_power=collided_power[g], photons=photons[g]) for g in range(groups)]


def exact_replays(scene: Scene, groups: Sequence[tuple[Rays, int]], *, steps: int, fresnel: str,
                  oracle: Oracle | None = None, max_photons: int = MAX_PHOTONS, engine: str = "drjit",
                  beams: bool = False, splits: int = 0, slots: int = 0, every: int = 1) -> list:
    """:func:`exact_emission`, then :func:`exact_collisions` from what it emitted: one
    :class:`Collisions` per (rays, seed) group. With the "drjit" engine the emitted
    state is made on the device (``Wavefront.emitted``: the records' float32 values,
    as the two steps pass them) and never comes back to numpy. ``beams``: as for
    :func:`exact_collisions`; ``splits``, ``slots``: fresnel_splits and photon_res², the
    rays (one per emission photon, indices < ``slots``) split into its batches first
    (``scenes.splitting.split_groups``, ``every``: split_every)."""
    oracle = oracle or Oracle(scene)
    groups = split_groups(groups, splits, slots, every)
    split = {"splits": splits, "slots": slots}
    if engine == "numpy":
        firsts = exact_emission(scene, groups, fresnel=fresnel, oracle=oracle, max_photons=max_photons, **split)
        return exact_collisions(scene, [(first, seed) for first, (_, seed) in zip(firsts, groups)], steps=steps,
                                fresnel=fresnel, oracle=oracle, max_photons=max_photons, engine=engine, beams=beams,
                                **split)
    c = ReplayConstants(scene, fresnel, beams=beams, **split)
    wavefront, light = _wavefront(c, oracle), np.asarray(scene.light.position, np.float64)

    def launch(part):
        distinct = list({id(rays): rays for rays, _ in part}.values())  # A's grid serves every replay seed
        where, hits = wavefront.light_hits(
            light, *(np.concatenate([np.asarray(getattr(rays, name)) for rays in distinct])
                     for name in ("direction", "power", "photon")))
        if hits is None:  # no photon of the launch reaches a surface: every replay empty
            nothing = (np.zeros(0, np.int64), np.zeros((0, 3)))
            return _collisions([], nothing, steps, np.zeros((len(part), 3)), [0] * len(part), beams=beams)
        bounds = np.cumsum([0] + [len(rays.photon) for rays in distinct])
        per_set = np.diff(np.searchsorted(where, bounds))  # each set's photons that hit (in input order)
        offset = dict(zip(map(id, distinct), np.cumsum([0, *per_set])))
        count = dict(zip(map(id, distinct), per_set))
        counts = [int(count[id(rays)]) for rays, _ in part]
        take = np.concatenate([offset[id(rays)] + np.arange(n) for (rays, _), n in zip(part, counts)])
        group, seed = _per_photon(part, counts)
        state, power = wavefront.emitted(hits, take.astype(np.int64), group, seed)
        kept, alive = wavefront.run(steps, state)
        starts = np.cumsum([0] + counts)
        emitted = np.stack([power[lo:hi].astype(np.float64).sum(axis=0) for lo, hi in zip(starts[:-1], starts[1:])])
        return _collisions(kept, alive, steps, emitted, counts, beams=beams)

    return _packed(groups, lambda group: len(group[0].photon), launch, max_photons)


def _numpy_steps(steps, group, seed, idx, o, d, inside, power, *, c, oracle) -> tuple:
    """The numpy engine: ``oracle.advance`` per step; as ``Wavefront.trace`` returns."""
    kept = []
    alive_group, alive_power = np.zeros(0, np.int64), np.zeros((0, 3))
    for step in range(1, steps + 1):
        s = advance(c, oracle, step, seed, idx, o, d, inside, power)
        # the segments in the medium that reached a surface or the medium's end (beams), or the
        # collisions; a split batch's share of another's is not splatted
        keep = splatted_mask(inside, s["status"], beams=c.beams) & ~silent(idx, step, c.splits, c.slots)
        if c.beams:
            row = {"start": o[keep], "length": s["along"][keep], "power": power[keep]}
        else:
            row = {"end": s["end"][keep], "power": s["new_power"][keep]}
        if keep.any():
            kept.append({"step": step, "group": group[keep], "photon": idx[keep], "direction": d[keep], **row})
        alive = alive_after(s["status"])
        if step == steps:
            alive_group, alive_power = group[alive], s["new_power"][alive]
        group, idx, seed = group[alive], idx[alive], seed[alive]
        o, d, inside, power = s["end"][alive], s["new_d"][alive], s["new_inside"][alive], s["new_power"][alive]
        if len(idx) == 0:
            break
    return kept, (alive_group, alive_power)


def _sum_by_group_and_step(out: np.ndarray, owner: np.ndarray, rows: np.ndarray) -> None:
    """out[g, k] (groups×steps×3) = the RGB power of group g's collisions at step k + 1:
    the rows' float32 values summed in float64 in row order, one run of rows at a time
    (``rows`` sorted by group, then step)."""
    if len(rows) == 0:
        return
    key = owner * out.shape[1] + (rows["step"].astype(np.int64) - 1)
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    out.reshape(-1, 3)[key[starts]] = np.add.reduceat(rows["power"].astype(np.float64), starts, axis=0)


def _group_sums(group: np.ndarray, power: np.ndarray, groups: int) -> np.ndarray:
    """groups×3: the RGB power of the photons of each group, as ``exact_photon_records``'
    caller sums them (the records' float32 values, summed in float64 in photon order)."""
    power = power.astype(np.float32).astype(np.float64)
    return np.stack([power[group == g].sum(axis=0) for g in range(groups)]) if len(group) else np.zeros((groups, 3))
