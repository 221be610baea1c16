"""The exact caustic images of the decomposition, as paired photon subsets: A, A_m (A
with the march exact), E_k, E_∞ (A's Fresnel), E_∞ (stochastic), E_em (the light's true
emission), E_∞,s (the true emission, small kernel, supersampled) and E_∞,s,τ (E_∞,s with
the transmittance to the eye exact). Every image but E_∞,s and E_∞,s,τ takes its kernels from
the seed's real frame (``experiment.kernels``: A's own for A, so A's subsets
average to the real frame whatever the splat mode); E_∞,s always takes the fixed small
kernel, so kernel_blur = E_∞,s − E_em is the blur of A's kernels.

Every E image replays from the emission ray: E_k and both E_∞ from A's own
emission rays (texel centres, or A's adaptive draw) traced exactly to their first
surface, so A's step-1 interaction at the light map is the intersection term's; E_em
and E_∞,s from photons jittered in every texel with the spot's exact profile, so the
emission grid's aliasing (and any emission rule's bias) is the emission term E_em − E_∞
(docs/decisions.md "The emission term").

In a heterogeneous medium A_m is each seed's frame rendered again by a variant of the
renderer with the control EXACT_MARCH (``Renderer.variant``: the same photons, their
powers from the exact optical depth), splatted with A's kernels; every E image is
splatted by that variant too (a beam's transmittance along itself exact), and E_∞,s,τ by
one with EXACT_EYE as well (docs/decisions.md "Heterogeneous media"). In a homogeneous
medium there is no march and no camera volume: A_m is A and E_∞,s,τ is E_∞,s.

The E_∞ images replay every emission texel EXACT_SUBPHOTONS times (the first replay
with A's random numbers, the others with seeds of their own, :func:`replay_seed`), each
at 1/EXACT_SUBPHOTONS of the power: the subsets stay paired by emission texel, and the
terms that difference E_∞ images with the reference (reflections, residual) lose the
noise of one exact photon per texel (docs/decisions.md "Sub-photons"). The
count is the measurement setting ``exact_subphotons`` (``experiment.measurement``:
a flag and a ``[measurement]`` key, part of a result's key)."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, cast

import numpy as np

from volcaustics.approx.emission import true_rays
from volcaustics.approx.light import LightFrustum
from volcaustics.approx.splat import beams_from_arrays, record_splats, splats_from_arrays, splatted
from volcaustics.approx.splat_modes import splat_mode
from volcaustics.experiment.exact import (
    ExactPhotons,
    pixel_footprint,
    subset_images,
)
from volcaustics.experiment.exact_store import (
    ALIASES,
    EXACT_IMAGES,
    exact_document,
    exact_key,
    load_exact,
    save_exact,
    with_aliases,
)
from volcaustics.experiment.kernels import frame_kernels, kernel_rule, splat_params
from volcaustics.experiment.measurement import EXACT_STEPS, SUBSET_BATCHES, MeasurementSettings
from volcaustics.reference.replay import exact_replays
from volcaustics.scenes.bounds import medium_bounds
from volcaustics.scenes.rng import pcg_hash

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Frame, Renderer
    from volcaustics.experiment.kernels import Kernels
    from volcaustics.reference.oracle import Oracle
    from volcaustics.scenes.model import Scene

# E_∞ and E_∞,s: docs/decisions.md "Exact steps and the small kernel"
SMALL_SUPERSAMPLE = 4        # E_∞,s: splatted at 4× and box-averaged (the reference's pixel filter)
# E_∞,s's kernel σ in fine pixels (0.025 pixel), integrated over each fine pixel for points and
# beams alike, so that it costs no aliasing and blurs little (docs/decisions.md "Points against
# beams", "The small kernel integrated")
SMALL_KERNEL_FINE_PIXELS = 0.1
_SUBPHOTON_SALT = 0x5EB9_07A1  # keeps the replays' seeds apart from the frames' seeds (seed, seed + 1, …)
# what the E images depend on beyond the parameters: part of their key (exact_store)
CONSTANTS = {"exact_steps": EXACT_STEPS, "small_supersample": SMALL_SUPERSAMPLE,
             "small_kernel_fine_pixels": SMALL_KERNEL_FINE_PIXELS, "subset_batches": SUBSET_BATCHES,
             "subphoton_salt": _SUBPHOTON_SALT}


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


def small_radius(scene: Scene, p: ApproxParams) -> float:
    """E_∞,s's kernel σ (m) at the camera's target distance: SMALL_KERNEL_FINE_PIXELS fine
    pixels."""
    return SMALL_KERNEL_FINE_PIXELS * pixel_footprint(scene.camera, cast(int, p.height) * SMALL_SUPERSAMPLE)


def small_kernel_params(scene: Scene, p: ApproxParams) -> ApproxParams:
    """What E_∞,s is splatted with whatever A's splat mode: the small kernel that every row
    carries (:func:`small_kernel_rows`), integrated over each fine pixel — points through
    the per-splat path (``splat = adaptive``), beams stay beams."""
    return dataclasses.replace(p, splat="beams" if splat_mode(p).beams else "adaptive", beam_width="fixed",
                               splat_radius=small_radius(scene, p))


def small_kernel_rows(rows: np.ndarray, small: ApproxParams) -> np.ndarray:
    """E_∞,s's rows, each carrying the small σ, which the splatter integrates over each fine
    pixel (splat/splat.frag.glsl, splat/beam.frag.glsl): near-parallel beams share their
    offset from the pixel centres, and so do collisions at a tight focus on the optical
    axis, so a point-sampled kernel would alias as a pattern there, not as noise
    (docs/decisions.md "The small kernel integrated")."""
    out = rows.copy()
    out["dir"][:, 3] = np.float32(small.splat_radius)
    if splat_mode(small).beams:
        out["power"][:, 3] = 0.0  # the same σ all along
    return out


def exact_images(scene: Scene, p: ApproxParams, frames: list[Frame], seeds: list[int], renderer: Renderer,
                 oracle: Oracle, settings: MeasurementSettings | None = None) -> dict:
    """Per seed, ``settings.subset_batches`` paired subset images
    (``experiment.exact.subset_images``) of A, E_k, E_∞ (A's Fresnel), E_∞
    (stochastic), E_em and E_∞,s, the E_∞ images from ``settings.exact_subphotons``
    replays of every texel (:func:`pooled`), ``settings.exact_steps`` steps each
    (``settings`` None: the report's measurement settings); all seeds' batches
    concatenated (batch j of every image: the same emission texels of one seed). Every
    exact image replays from the emission ray (:func:`_exact_batches`).
    The E images are read from ``exact_store`` when a point with the same emission,
    replay and splat stored them (``exact_reused``); else every replay of one Fresnel
    mode is one wavefront (``reference.replay``) and they are stored."""
    settings = settings or MeasurementSettings()
    subphotons, subset_batches, exact_steps = settings.exact_subphotons, settings.subset_batches, settings.exact_steps
    constants = {**CONSTANTS, "exact_steps": exact_steps, "subset_batches": subset_batches}
    document = exact_document(scene, p, seeds, subphotons, constants, renderer.controls)
    key = exact_key(document)
    approx, kernels = approx_subsets(scene, p, frames, seeds, renderer, subset_batches)
    march = renderer.variant({"EXACT_MARCH": 1}) if scene.medium.is_heterogeneous else renderer
    marched = approx if march is renderer else np.concatenate([
        _frame_subsets(march, scene, p, _collided(march.render(scene, dataclasses.replace(p, seed=seed)), p),
                       seed, kernel, subset_batches) for seed, kernel in zip(seeds, kernels)])
    exact = load_exact(key, document)
    reused = exact is not None
    if exact is None:
        exact = _exact_batches(scene, p, kernels, seeds, march, oracle, subphotons, subset_batches, exact_steps)
        save_exact(key, document, exact)
    return {"batches": {"approx": approx, "approx_exact_march": marched, **exact["batches"]}, "alive": exact["alive"],
            "small_radius": exact["small_radius"], "subphotons": subphotons, "exact_key": key,
            "exact_reused": reused, "exact_steps": exact_steps, "subset_batches": subset_batches,
            "kernels": kernel_rule(p)}


def approx_subsets(scene: Scene, p: ApproxParams, frames: list[Frame], seeds: list[int], renderer: Renderer,
                   batches: int = SUBSET_BATCHES) -> tuple[np.ndarray, list[Kernels]]:
    """(A's paired subset images, every seed's kernels): per seed, ``batches`` subset
    images of its frame's medium collisions with the frame's own kernels (so their mean
    is the frame's caustic, whatever the splat mode), all seeds' concatenated; and per
    seed the kernels of its real frame (``kernels.frame_kernels``) for the E images."""
    images, kernels = [], []
    for frame, seed in zip(frames, seeds):
        collided = _collided(frame, p)
        kernel = frame_kernels(renderer, scene, p, collided)
        images.append(_frame_subsets(renderer, scene, p, collided, seed, kernel, batches))
        kernels.append(kernel)
    return np.concatenate(images), kernels


def _collided(frame: Frame, p: ApproxParams) -> np.ndarray:
    """The frame's records of the medium collisions it splats."""
    return np.concatenate([r[splatted(r, p)] for r in frame.records])


def _frame_subsets(renderer, scene, p, collided: np.ndarray, seed: int, kernel, batches: int) -> np.ndarray:
    """``batches`` paired subset images of a frame's medium collisions (:func:`_collided`) with ``kernel``."""
    splats = record_splats(collided, p.splat)
    return _subsets(renderer, scene, dataclasses.replace(splat_params(p), seed=seed),
                    kernel(splats, collided["photon"], collided["step"]), collided["photon"], batches)


def _subsets(renderer, scene, params, splats, photon, batches: int, supersample: int = 1) -> np.ndarray:
    """``batches`` paired subset images of ``splats`` (``exact.subset_images``), splatted
    with ``params`` (its seed, size and splat mode) at ``supersample``× the pixels."""
    return subset_images(renderer, splats, photon, params.photon_res, batches, params, scene,
                         supersample=supersample)


def _exact_batches(scene, p, kernels, seeds, renderer, oracle, subphotons: int, batches: int, steps: int) -> dict:
    """The E images of :func:`exact_images` (``exact_store.EXACT_IMAGES``), their alive
    fractions and the small kernel, computed. Every one replays from the emission ray
    (``reference.replay.exact_emission``): E_k, E_∞ (A's Fresnel) and E_∞ (stochastic)
    from A's own emission rays (``Renderer.emission_rays``: texel centres or the
    adaptive draw; E_k is replay 0, A's random numbers, cut at ``steps``), E_em and
    E_∞,s from the light's true distribution (``approx.emission.true_rays``: jittered
    in every texel, the spot's exact profile), with the same replay seeds. ``kernels``:
    per seed, the kernels of its real frame (``kernels.frame_kernels``) for every image
    but E_∞,s and E_∞,s,τ, which take the fixed small kernel whatever A's splat mode.
    ``renderer`` splats them (in a heterogeneous medium: the variant with the march
    exact), E_∞,s,τ its variant with EXACT_EYE too."""
    eye = renderer.variant({"EXACT_EYE": 1}) if scene.medium.is_heterogeneous else None
    out: dict = {name: [] for name in EXACT_IMAGES if eye is not None or name not in ALIASES}
    alive: dict = {}
    small = small_kernel_params(scene, p)
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    replay_seeds = [[replay_seed(seed, m) for m in range(subphotons)] for seed in seeds]
    own = [(rays, s) for rays, seeds_of in zip(renderer.emission_rays(scene, p, seeds), replay_seeds)
           for s in seeds_of]
    true = [(true_rays(scene.light, frustum, p.photon_res, s), s) for seeds_of in replay_seeds for s in seeds_of]
    stochastic = replayed(scene, p, "stochastic", own + true, oracle, steps)  # one wavefront for both emissions
    everything_all, true_all = stochastic[:len(own)], stochastic[len(own):]
    same_all = (everything_all if p.fresnel == "stochastic" and not p.fresnel_splits
                else replayed(scene, p, p.fresnel, own, oracle, steps, splits=p.fresnel_splits))
    for i, (kernel, seed) in enumerate(zip(kernels, seeds)):
        ps = dataclasses.replace(splat_params(p), seed=seed)
        mine = slice(i * subphotons, (i + 1) * subphotons)
        same, everything, emitted = (pooled(replays[mine]) for replays in (same_all, everything_all, true_all))
        e_k = _cut(same_all[i * subphotons], p.steps)
        for name, photons in (("exact_steps", e_k), ("exact_all_same", same), ("exact_all", everything),
                              ("exact_emission", emitted)):
            if name == "exact_all" and same_all is everything_all:  # A's Fresnel is stochastic: the same photons
                out[name].append(out["exact_all_same"][-1])
                continue
            out[name].append(_subsets(renderer, scene, ps, kernel(photons.splats, photons.photon, photons.step),
                                      photons.photon, batches))
        small_rows = small_kernel_rows(emitted.splats, small)  # E_∞,s's and E_∞,s,τ's rows: one copy
        for name, splatter in (("exact_all_small", renderer), ("exact_all_small_eye", eye)):
            if splatter is None:
                continue
            out[name].append(_subsets(splatter, scene, dataclasses.replace(small, seed=seed), small_rows,
                                      emitted.photon, batches, SMALL_SUPERSAMPLE))
        for name, photons in {p.fresnel: same, "stochastic": everything, "true_emission": emitted}.items():
            alive.setdefault(name, []).append(photons.alive_fraction)
    return {"batches": with_aliases({name: np.concatenate(images) for name, images in out.items()}), "alive": alive,
            "small_radius": small.splat_radius}


def _cut(photons: ExactPhotons, steps: int) -> ExactPhotons:
    """The collisions of ``photons`` at steps 1..``steps``: the replay cut there (its
    first steps are the same whatever follows them). Its power budget is not kept."""
    keep = photons.step <= steps
    return dataclasses.replace(photons, splats=photons.splats[keep], photon=photons.photon[keep],
                               step=photons.step[keep], params={**photons.params, "steps": steps})


def replayed(scene: Scene, p: ApproxParams, fresnel: str, groups: list, oracle: Oracle,
             steps: int, splits: int = 0) -> list[ExactPhotons]:
    """One :class:`ExactPhotons` per (rays, seed) of ``groups``: the rays emitted exactly
    and replayed ``steps`` steps with ``fresnel`` and that seed (split into ``splits`` + 1
    batches first, ``scenes.splitting``), all of them one wavefront on the device
    (``reference.replay.exact_replays``)."""
    beams = splat_mode(p).beams
    done = exact_replays(scene, groups, steps=steps, fresnel=fresnel, oracle=oracle, beams=beams, splits=splits,
                         slots=p.photon_res**2, every=p.split_every)
    used = {**p.to_dict(), "steps": steps, "fresnel": fresnel, "emission_fresnel": fresnel, "fresnel_splits": splits}
    return [ExactPhotons(splats=beams_from_arrays(c.rows["start"], c.rows["direction"], c.rows["length"],
                                                  c.rows["power"]) if beams
                         else splats_from_arrays(c.rows["end"], c.rows["direction"], c.rows["power"]),
                         photon=c.rows["photon"].astype(np.uint32), step=c.rows["step"].astype(np.int64),
                         emitted_power=c.emitted_power, alive_power=c.alive_power,
                         collided_power=c.collided_power, photons=c.photons, params={**used, "seed": int(s)})
            for c, (_, s) in zip(done, groups)]
