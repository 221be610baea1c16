"""Reference renders: every component in independent batches, with per-pixel
variance of the mean and its noise floor, served from, continued in and stored to
the cache.

Two independent streams of batches: the light tracer's (``caustic``) and the
camera integrator's (``fog``, ``direct``, ``mask_specular``). With a fixed budget
each stream renders ``batches`` batches; with ``target_noise`` batches are added
to a stream until the noise floor (Σ var / Σ mean² over non-glass pixels) of each
of its components is at most its target, or the photon or time cap stops it (the
manifest's ``stopped_by`` says which). Layers (docs/conventions.md names) and their
variances: ``caustic``, ``fog``, ``direct``, ``combined`` (their sum; the streams
are independent, so its variance is the caustic's plus that of fog + direct),
``mask_specular``; ``<layer>_var`` holds the variance of the mean.

Batches render in this process, or on a pool of workers (:func:`render_references`
with ``pool``: every batch a task, ``tasks``; read and added in the serial order,
``sources``); the cache is written here either way.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from volcaustics.infra.imageio import png_bytes, tonemap_srgb8
from volcaustics.scenes.formats import MASK_LAYER

from .. import cache
from ..cache import ReferenceResult, for_caller
from ..request import RenderRequest, resolve
from ..served import meets
from ..settings import ReferenceSettings
from . import orders as scattering
from .batches import CAMERA, LIGHT_GROUPS
from .sources import BatchError, BatchPool, InProcess, Pooled
from .state import RenderState, format_floors, stop_reason, stream_pending
from .tasks import add_batch

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene


def render_into_state(request: RenderRequest, key: str, state: RenderState | None, source: InProcess | Pooled, *,
                      progress: bool) -> tuple:
    """Render batches of both streams into ``state`` (a fresh one if None) until the
    settings are met (module docstring), read from ``source`` (``sources``) in the order
    the serial path renders them; returns (state, stopped_by, seconds of this call: its
    batches' own, wherever they rendered; {process: its batches of this call})."""
    from tqdm import tqdm

    settings = request.settings
    state = state or RenderState.for_settings(settings)
    t0 = time.perf_counter()
    source.want(key, request, _minimum(state, settings))
    total = None if settings.targets() else sum(max(0, settings.batches - s.n) for s in state.streams().values())
    bar = tqdm(total=total, desc=f"reference {request.scene.name}", unit="batch", disable=not progress)
    timed_out = False
    where: dict
    spent, where = 0.0, {}
    floors = state.floors()
    while True:
        # the camera's batch first: its glass mask chooses the pixels of every stream's totals
        streams = sorted((s for s in state.streams() if stream_pending(state, settings, s, floors)),
                         key=lambda s: s != CAMERA)
        if not streams:
            break
        minimum = min(s.n for s in state.streams().values()) >= settings.batches  # caps apply beyond the minimum
        if settings.targets() and minimum and time.perf_counter() - t0 > settings.max_seconds:
            timed_out = True
            break
        for stream in streams:
            index = state.streams()[stream].n
            if index >= settings.batches:  # beyond the minimum: a few ahead, for the workers (unused ones dropped)
                source.want(key, request, [(stream, i) for i in range(index, index + source.spare)])
            images, seconds, process = source.images(key, request, stream, index)
            add_batch(state, stream, images)
            spent += seconds
            where[process] = where.get(process, 0) + 1
            bar.update(1)
        floors = state.floors()
        state.note_targets(settings.targets(), floors, spent)
        bar.set_postfix_str(format_floors(floors))
    bar.close()
    state.seconds += spent
    return state, stop_reason(state, settings, timed_out), spent, where


def _minimum(state: RenderState, settings: ReferenceSettings) -> list:
    """The (stream, index) of every batch up to the settings' ``batches`` not rendered
    yet, round by round, each round's camera batch first: the order they are read in."""
    streams = sorted(state.streams(), key=lambda s: s != CAMERA)
    counts = {s: state.streams()[s].n for s in streams}
    return [(s, i) for i in range(min(counts.values(), default=0), settings.batches) for s in streams
            if i >= counts[s]]


def render_batches(scene: Scene, settings: ReferenceSettings, *, mode: str = "caustic", progress: bool = True) -> dict:
    """Render without the cache; returns {layer: (mean, var)} for the colour layers
    and the mask, plus timing, counts and noise floors under the key ``"_info"``."""
    from ..mi_setup import variant_name

    request = resolve(scene, settings, mode)
    key = cache.request_key(request, variant_name())
    source = InProcess()
    try:
        state, stopped_by, seconds, _ = render_into_state(request, key, None, source, progress=progress)
    finally:
        source.drop(key)
    out = state.layers()
    out["_info"] = _info(state, request.settings, stopped_by, seconds)
    return out


def _info(state: RenderState, settings: ReferenceSettings, stopped_by: str, seconds: float) -> dict:
    return {"seconds": state.seconds, "seconds_this_call": seconds, "stopped_by": stopped_by,
            "photons": state.light.n * settings.photons_per_batch(), "batches": state.light.n,
            "camera_batches": state.camera.n, "camera_spp": state.camera.n * settings.camera_spp_per_batch(),
            "orders_batches": state.orders.n if state.orders is not None else 0,
            "orders_spp_per_batch": settings.orders_spp_per_batch() if state.orders is not None else 0,
            "max_scatter": settings.max_scatter, "convergence": state.convergence(),
            "photon_spp_per_batch": settings.photon_spp_per_batch(),
            "camera_spp_per_batch": settings.camera_spp_per_batch(), "noise_floor": state.floors(),
            "total_variance_ratio": state.total_variance_ratios(), "seconds_to_target": dict(state.floor_seconds)}


def _resumable(arrays: dict | None, settings: ReferenceSettings) -> RenderState | None:
    """The batch state ``arrays`` (cache.read_state) to continue, or None (render afresh)
    when there is none or it is not a state of this image: arrays missing, of another
    size, or not finite. A damaged state is never added to."""
    if arrays is None:
        return None
    try:
        state = RenderState.from_arrays(arrays)
    except (KeyError, ValueError, TypeError):
        return None
    shape = (settings.height, settings.width, 3)
    wanted = scattering.stream_images(settings.max_scatter) if settings.max_scatter > 1 else None
    if (state.orders.names if state.orders is not None else None) != wanted:
        return None
    images = [a for stats in state.streams().values() for a in (*stats.sums.values(), *stats.squares.values())]
    groups = [g for stats in state.streams().values() for g in stats.group_sums.values()]
    if any(len(g) != LIGHT_GROUPS for g in groups):
        return None
    images += [image for g in groups for image in g]
    if state.mask is None or state.mask.shape != shape[:2] or not np.isfinite(state.seconds) or state.seconds < 0:
        return None
    if state.total_keep is None or state.total_keep.shape != shape[:2]:
        return None
    return state if all(a.shape == shape and np.isfinite(a).all() for a in images) else None


def render_reference(scene: Scene, settings: ReferenceSettings | None = None, *, mode: str = "caustic",
                     force: bool = False, progress: bool = True, pool: BatchPool | None = None) -> ReferenceResult:
    """The reference for ``scene``: from the cache when a valid entry meets ``settings``
    (and not ``force``); an entry that does not (fewer batches, a noise floor above
    ``target_noise``) is continued batch by batch, never thrown away; else rendered and
    stored. The image is ``settings.width × height`` (unset: the scene camera's).
    ``mode``: which light paths the caustic layer counts (settings.MODES). ``pool``: as
    for :func:`render_references`."""
    return render_references([(scene, settings, mode)], force=force, progress=progress, pool=pool)[0]


@dataclass
class _Plan:
    scene: Any  # as the caller gave it (its camera's size may not be the request's)
    request: RenderRequest
    key: str
    state: RenderState | None  # a cached state to continue


def render_references(jobs: Iterable[tuple[Scene, ReferenceSettings | None, str]], *, force: bool = False,
                      progress: bool = True, pool: BatchPool | None = None) -> list:
    """:func:`render_reference` of every job ((scene, settings, mode)), in order. With
    ``pool`` (an open ``reports.measuring.pools.executors`` pool) the batches of every reference
    that renders go to its workers at once; each is added here in the order the serial
    path renders it (``sources.Pooled``). A job whose key an earlier job renders takes
    that render."""
    from ..mi_setup import variant_name

    plans = [_plan(scene, resolve(scene, settings, mode), variant_name(), force) for scene, settings, mode in jobs]
    source = Pooled(pool) if pool is not None else InProcess()
    rendering = {p.key: p for p in plans if isinstance(p, _Plan)}
    for plan in rendering.values():
        source.want(plan.key, plan.request, _minimum(plan.state or RenderState.for_settings(plan.request.settings),
                                                     plan.request.settings))
    done: dict = {}
    for plan in rendering.values():  # on an exception the pool's owner stops what is out
        done[plan.key] = _finish(plan, source, progress)
        source.drop(plan.key)
    return [done[p.key] if isinstance(p, _Plan) else p for p in plans]


def _plan(scene, request: RenderRequest, variant: str, force: bool):
    """The cached ReferenceResult that meets the request, or the _Plan of its render."""
    settings = request.settings
    key = cache.request_key(request, variant)
    state = None
    if not force:
        served = cache.lookup(request)
        if served is not None:
            served_key, manifest, layers = served
            if meets(manifest, settings):
                return ReferenceResult(served_key, for_caller(manifest, scene), cached=True, layers=layers)
            if served_key == key:
                state = _resumable(cache.read_state(served_key, manifest), settings)
    cache.manifest_path(key, write=True)  # a render is stored: a read-only cache is refused before it, not after
    return _Plan(scene, request, key, state)


def _finish(plan: _Plan, source, progress: bool) -> ReferenceResult:
    """Render ``plan`` from ``source`` and store it."""
    from ..mi_setup import drjit_version, mitsuba_version, variant_name

    scene, request, key, settings = plan.scene, plan.request, plan.key, plan.request.settings
    try:
        state, stopped_by, seconds, where = render_into_state(request, key, plan.state, source, progress=progress)
    except BatchError as exc:
        raise BatchError(f"the reference of {scene.name}: {exc} (nothing of it was stored)") from exc
    info = _info(state, settings, stopped_by, seconds)
    layers = {}
    for name, (mean, var) in state.layers().items():
        layers[name] = mean
        if name != MASK_LAYER:
            layers[f"{name}_var"] = var
    manifest = {
        "scene": scene.name, "scene_hash": scene.scene_hash(), "settings": settings.to_dict(), "mode": request.mode,
        "photons": info["photons"], "batches": info["batches"], "camera_batches": info["camera_batches"],
        "camera_spp": info["camera_spp"], "photon_spp_per_batch": info["photon_spp_per_batch"],
        "orders_batches": info["orders_batches"], "orders_spp_per_batch": info["orders_spp_per_batch"],
        "max_scatter": info["max_scatter"],
        "convergence": info["convergence"],
        "camera_spp_per_batch": info["camera_spp_per_batch"], "seed": settings.seed,
        "noise_floor": info["noise_floor"], "total_variance_ratio": info["total_variance_ratio"],
        "target_noise": settings.targets() or None,
        "seconds_to_target": info["seconds_to_target"],
        "stopped_by": stopped_by, "wall_seconds": info["seconds"],
        "seconds_this_call": seconds, "rendered_by": where,  # process → its batches of this call
        "mitsuba_variant": variant_name(), "mitsuba_version": mitsuba_version(),
        "drjit_version": drjit_version(), "reference_code_version": cache.code_version(),
    }
    header = {"volcaustics_scene": scene.name, "volcaustics_scene_hash": scene.scene_hash(),
              "volcaustics_renderer": "reference", "volcaustics_manifest": json.dumps(manifest, default=float)}
    manifest = cache.store(key, layers, manifest, header, png_bytes(tonemap_srgb8(layers["combined"])),
                           state=state.arrays())
    return ReferenceResult(key, manifest, cached=False, layers=layers)
