"""The exact caustic images of the decomposition, as paired photon subsets: A, E_k,
E_∞ (A's Fresnel), E_∞ (stochastic) and E_∞,s (small kernel, supersampled). With
splat = adaptive, A is splatted with its own kernels and the E images with the kernels
A gave the same photons (:func:`_paired_kernels`), so kernel_blur = E_∞ − E_∞,s is the
adaptive kernel's blur.

The E_∞ images replay every emission texel EXACT_SUBPHOTONS times (the first replay
with A's random numbers, the others with seeds of their own, :func:`replay_seed`), each
at 1/EXACT_SUBPHOTONS of the power: the subsets stay paired by emission texel, and the
terms that difference E_∞ images with the reference (reflections, residual) lose the
noise of one exact photon per texel (issue 25; docs/decisions.md "Sub-photons"). The
count is the measurement setting ``exact_subphotons`` (``reports.experiment.measurement``:
a flag and a ``[measurement]`` key, part of a result's key)."""

from __future__ import annotations

import dataclasses

import numpy as np

from volcaustics.approx.params import ParamError
from volcaustics.approx.splat import record_sigma, splats_from_arrays
from volcaustics.reference.replay import exact_collisions
from volcaustics.reports.experiment.exact import (
    ExactPhotons,
    photons_from_records,
    pixel_footprint,
    subset_images,
)
from volcaustics.reports.experiment.exact_store import EXACT_IMAGES, exact_document, exact_key, load_exact, save_exact
from volcaustics.scenes.formats import STATUS_COLLIDED
from volcaustics.scenes.rng import pcg_hash

# E_∞ and E_∞,s: docs/decisions.md "Exact steps and the small kernel"
EXACT_STEPS = 128            # E_∞: < 0.1% of the power alive after them on every built-in
SMALL_SUPERSAMPLE = 4        # E_∞,s: splatted at 4× and box-averaged (the reference's pixel filter)
SMALL_KERNEL_FINE_PIXELS = 0.6  # E_∞,s kernel σ in fine pixels (0.15 pixel): aliasing ≈ 0.2%
SUBSET_BATCHES = 8           # paired photon subsets per seed of A and the E images: the decomposition's noise
EXACT_SUBPHOTONS = 16        # exact replays of each emission texel in the E_∞ images (docs/decisions.md "Sub-photons")
_SUBPHOTON_SALT = 0x5EB9_07A1  # keeps the replays' seeds apart from the frames' seeds (seed, seed + 1, …)
# what the E images depend on beyond the parameters: part of their key (exact_store)
CONSTANTS = {"exact_steps": EXACT_STEPS, "small_supersample": SMALL_SUPERSAMPLE,
             "small_kernel_fine_pixels": SMALL_KERNEL_FINE_PIXELS, "subset_batches": SUBSET_BATCHES,
             "subphoton_salt": _SUBPHOTON_SALT}


def subphotons_setting(value: int | None = None) -> int:
    """The sub-photons of a measurement: ``value`` (the ``exact_subphotons`` measurement
    setting, ``reports.experiment.measurement``), EXACT_SUBPHOTONS when None; ParamError
    unless an integer in [1, 64]."""
    if value is None:
        return EXACT_SUBPHOTONS
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 64:
        raise ParamError(f"exact_subphotons = {value!r}: expected an integer in [1, 64] (exact replays of each "
                         f"emission texel in the decomposition's E_∞ images; default {EXACT_SUBPHOTONS})")
    return value


def replay_seed(seed: int, replay: int) -> int:
    """The seed of exact replay ``replay`` of a frame with ``seed``: the frame's own for
    replay 0 (A's random numbers), a PCG hash of both otherwise."""
    if replay == 0:
        return seed
    return int(pcg_hash(np.uint32(seed) ^ pcg_hash(np.uint32(_SUBPHOTON_SALT + replay))))


def pooled(replays: list) -> ExactPhotons:
    """Several exact replays of one emission grid as one set of photons: their splats
    together at 1/len(replays) of their power each (the same texel indices, so subsets
    stay paired), the power budgets averaged."""
    n = len(replays)
    if n == 1:
        return replays[0]
    splats = np.concatenate([r.splats for r in replays])
    splats["power"] /= np.float32(n)
    first = replays[0]
    return dataclasses.replace(
        first, splats=splats, photon=np.concatenate([r.photon for r in replays]),
        step=np.concatenate([r.step for r in replays]),
        emitted_power=np.mean([r.emitted_power for r in replays], axis=0),
        alive_power=np.mean([r.alive_power for r in replays], axis=0),
        collided_power=np.mean([r.collided_power for r in replays], axis=0),
        params={**first.params, "subphotons": n})


def small_radius(scene, p) -> float:
    return SMALL_KERNEL_FINE_PIXELS * pixel_footprint(scene.camera, p.height * SMALL_SUPERSAMPLE)


def _paired_kernels(collided: np.ndarray, sigma: np.ndarray | None):
    """For splat = adaptive, a function giving exact photons (``ExactPhotons``) the
    kernels the approximation gave them: the kernel of the same photon's collision at the
    same step of A (``collided``, kernels ``sigma``), else (A's photon did not collide
    there: another path, or a step beyond A's) the median of A's kernels. For splat =
    fixed, the photons' splats as they are (splat_radius)."""
    if sigma is None:
        return lambda photons: photons.splats
    order = np.lexsort((collided["step"], collided["photon"]))
    keys = collided["photon"][order].astype(np.int64) << 16 | collided["step"][order].astype(np.int64)
    sorted_sigma, fallback = sigma[order], np.float32(np.median(sigma)) if len(sigma) else np.float32(0)

    def kernels(photons):
        wanted = photons.photon.astype(np.int64) << 16 | photons.step.astype(np.int64)
        at = np.clip(np.searchsorted(keys, wanted), 0, max(len(keys) - 1, 0))
        found = (keys[at] == wanted) if len(keys) else np.zeros(len(wanted), bool)
        splats = photons.splats.copy()
        splats["dir"][:, 3] = np.where(found, sorted_sigma[at] if len(keys) else fallback, fallback)
        return splats

    return kernels


def exact_images(scene, p, frames, replays, seeds, renderer, oracle, subphotons: int | None = None) -> dict:
    """Per seed, SUBSET_BATCHES paired subset images (``reports.experiment.exact.subset_images``)
    of A, E_k, E_∞ (A's Fresnel), E_∞ (stochastic) and E_∞,s, the E_∞ images from
    ``subphotons`` replays of every texel (:func:`pooled`; None: :func:`subphotons_setting`);
    all seeds' batches concatenated (batch j of every image: the same emission texels of
    one seed). The E images are read from ``exact_store`` when a point with the same
    emission, replay and splat stored them (``exact_reused``); else every E_∞ replay of
    the point is one wavefront (``reference.replay``) and they are stored."""
    subphotons = subphotons_setting() if subphotons is None else subphotons
    document = exact_document(scene, p, seeds, subphotons, CONSTANTS)
    key = exact_key(document)
    # each frame's medium collisions: A's splats, and (splat = adaptive) the kernels E pairs with
    collisions = [np.concatenate([r[r["status"] == STATUS_COLLIDED] for r in frame.records]) for frame in frames]
    exact = load_exact(key, document)
    reused = exact is not None
    if exact is None:
        exact = _exact_batches(scene, p, frames, collisions, replays, seeds, renderer, oracle, subphotons)
        save_exact(key, document, exact)
    approx = []
    for collided, seed in zip(collisions, seeds):
        sigma = record_sigma(collided, p)
        splats = splats_from_arrays(collided["end"], collided["direction"], collided["power"], sigma)
        approx.append(_subsets(renderer, scene, p, splats, collided["photon"], dataclasses.replace(p, seed=seed)))
    return {"batches": {"approx": np.concatenate(approx), **exact["batches"]}, "alive": exact["alive"],
            "small_radius": exact["small_radius"], "subphotons": subphotons, "exact_key": key,
            "exact_reused": reused}


def _subsets(renderer, scene, p, splats, photon, params, supersample: int = 1) -> np.ndarray:
    return subset_images(renderer, splats, photon, p.photon_res, SUBSET_BATCHES, params, scene,
                         supersample=supersample)


def _exact_batches(scene, p, frames, collisions, replays, seeds, renderer, oracle, subphotons: int) -> dict:
    """The E images of :func:`exact_images` (``exact_store.EXACT_IMAGES``), their alive
    fractions per Fresnel mode and the small kernel, computed."""
    out = {name: [] for name in EXACT_IMAGES}
    alive = {}
    small = dataclasses.replace(p, splat_radius=small_radius(scene, p))
    firsts = [frame.records[0] for frame in frames]
    same_all = _replayed(scene, p, p.fresnel, firsts, seeds, subphotons, oracle)
    everything_all = same_all
    if p.fresnel != "stochastic":  # the stochastic emission of every replay seed, then its replay
        sto = dataclasses.replace(p, fresnel="stochastic", steps=1, fog_steps=1)
        firsts_sto = renderer.first_records(scene, sto, [replay_seed(seed, m) for seed in seeds
                                                         for m in range(subphotons)])
        everything_all = _replayed(scene, p, "stochastic", firsts_sto, seeds, subphotons, oracle)
    for frame, collided, replay, seed, same, everything in zip(frames, collisions, replays, seeds, same_all,
                                                                everything_all):
        ps = dataclasses.replace(p, seed=seed)
        kernels = _paired_kernels(collided, record_sigma(collided, p))
        e_k = photons_from_records(replay, frame.records[0], ps, steps=p.steps, fresnel=p.fresnel)
        for name, photons in (("exact_steps", e_k), ("exact_all_same", same), ("exact_all", everything)):
            out[name].append(_subsets(renderer, scene, p, kernels(photons), photons.photon, ps))
        out["exact_all_small"].append(_subsets(renderer, scene, p, everything.splats, everything.photon,
                                               dataclasses.replace(small, seed=seed), SMALL_SUPERSAMPLE))
        for fresnel, photons in {p.fresnel: same, "stochastic": everything}.items():
            alive.setdefault(fresnel, []).append(photons.alive_fraction)
    return {"batches": {name: np.concatenate(images) for name, images in out.items()}, "alive": alive,
            "small_radius": small.splat_radius}


def _replayed(scene, p, fresnel: str, firsts: list, seeds, subphotons: int, oracle) -> list:
    """Per seed, the pooled E_∞ photons (:func:`pooled`) of its ``subphotons`` replays
    with ``fresnel``: replay m of seed s starts from ``firsts`` (one per seed, shared by
    its replays; or one per replay, seed-major) with seed ``replay_seed(s, m)``. All of
    them are one wavefront (``reference.replay.exact_collisions``)."""
    starts = [firsts[i if len(firsts) == len(seeds) else i * subphotons + m]
              for i in range(len(seeds)) for m in range(subphotons)]
    replay_seeds = [replay_seed(seed, m) for seed in seeds for m in range(subphotons)]
    done = exact_collisions(scene, list(zip(starts, replay_seeds)), steps=EXACT_STEPS, fresnel=fresnel, oracle=oracle)
    used = {**p.to_dict(), "steps": EXACT_STEPS, "fresnel": fresnel, "emission_fresnel": fresnel}
    photons = [ExactPhotons(splats=splats_from_arrays(c.rows["end"], c.rows["direction"], c.rows["power"]),
                            photon=c.rows["photon"].astype(np.uint32), step=c.rows["step"].astype(np.int64),
                            emitted_power=c.emitted_power, alive_power=c.alive_power,
                            collided_power=c.collided_power, photons=c.photons, params={**used, "seed": s})
               for c, s in zip(done, replay_seeds)]
    return [pooled(photons[i * subphotons:(i + 1) * subphotons]) for i in range(len(seeds))]
