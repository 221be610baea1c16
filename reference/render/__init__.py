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
"""

from __future__ import annotations

import json
import time

import numpy as np

from volcaustics.infra.imageio import png_bytes, tonemap_srgb8
from volcaustics.infra.interrupts import interruptible
from volcaustics.scenes.formats import MASK_LAYER

from .. import cache
from ..cache import ReferenceResult, for_caller
from ..request import RenderRequest, resolve
from ..settings import ReferenceSettings
from . import orders as scattering
from .batches import (
    CAMERA,
    LIGHT,
    LIGHT_GROUPS,
    ORDERS,
    STREAM_IMAGES,
    BatchStats,
    batch_seed,
    noise_floor,
    total_variance_ratio,
)


class RenderState:
    """Everything rendered so far for one cache entry: the batch statistics of its
    streams (reference.batches; ``orders`` only with K > 1 scattering orders), the glass
    mask and the seconds spent (all calls)."""

    def __init__(self, light: BatchStats | None = None, camera: BatchStats | None = None,
                 mask: np.ndarray | None = None, seconds: float = 0.0, floor_seconds: dict | None = None,
                 orders: BatchStats | None = None, total_keep: np.ndarray | None = None):
        self.light = light or BatchStats(STREAM_IMAGES[LIGHT], groups=LIGHT_GROUPS)
        self.camera = camera or BatchStats(STREAM_IMAGES[CAMERA])
        self.orders = orders
        self.mask = mask
        # the pixels every batch's totals are over: those the first camera batch saw free of
        # glass (rendered before any other stream's first batch), as the metrics compare
        self.total_keep = total_keep
        self.seconds = seconds
        # component -> {"floor": f, "seconds": s}: render time (all calls) at which its noise
        # floor first came down to f, the lowest target asked of it so far
        self.floor_seconds = floor_seconds or {}

    @classmethod
    def for_settings(cls, settings: ReferenceSettings) -> "RenderState":
        """An empty state for ``settings``: with the orders stream when max_scatter > 1."""
        orders = (BatchStats(scattering.stream_images(settings.max_scatter), groups=LIGHT_GROUPS,
                             grouped=scattering.GROUPED) if settings.max_scatter > 1 else None)
        return cls(orders=orders)

    def streams(self) -> dict:
        """Stream name → its BatchStats."""
        out = {LIGHT: self.light, CAMERA: self.camera}
        if self.orders is not None:
            out[ORDERS] = self.orders
        return out

    def arrays(self) -> dict:
        out = {**self.light.arrays(LIGHT), **self.camera.arrays(CAMERA), "seconds": np.asarray(self.seconds),
               "floor_seconds": np.asarray(json.dumps(self.floor_seconds))}
        if self.orders is not None:
            out.update(self.orders.arrays(ORDERS))
            out[f"{ORDERS}/names"] = np.asarray(json.dumps(self.orders.names))
        if self.mask is not None:
            out["mask"] = self.mask
        if self.total_keep is not None:
            out["total_keep"] = self.total_keep
        return out

    @classmethod
    def from_arrays(cls, arrays: dict) -> "RenderState":
        orders = None
        if f"{ORDERS}/names" in arrays:
            orders = BatchStats.from_arrays(json.loads(str(arrays[f"{ORDERS}/names"])), arrays, ORDERS, LIGHT_GROUPS,
                                            scattering.GROUPED)
        return cls(BatchStats.from_arrays(STREAM_IMAGES[LIGHT], arrays, LIGHT, LIGHT_GROUPS),
                   BatchStats.from_arrays(STREAM_IMAGES[CAMERA], arrays, CAMERA),
                   np.array(arrays["mask"]) if "mask" in arrays else None, float(arrays["seconds"]),
                   json.loads(str(arrays["floor_seconds"])) if "floor_seconds" in arrays else None, orders,
                   np.array(arrays["total_keep"], bool) if "total_keep" in arrays else None)

    def note_targets(self, targets: dict, floors: dict, elapsed: float) -> None:
        """Record when each target component's floor (``floors``, :meth:`floors`) first met
        its target (``elapsed``: seconds of this call, added to the earlier calls')."""
        for name, target in targets.items():
            known = self.floor_seconds.get(name)
            if floors[name] is not None and floors[name] <= target and (known is None or known["floor"] > target):
                self.floor_seconds[name] = {"floor": target, "seconds": self.seconds + elapsed}

    def layers(self) -> dict:
        """{layer: (mean, var)} float32 for the colour layers and the mask. The streams are
        independent, so combined's variance is the caustic's plus that of fog + direct."""
        light, camera = self.light, self.camera
        out = {"caustic": (light.mean("caustic"), light.var("caustic")),
               "fog": (camera.mean("fog"), camera.var("fog")),
               "direct": (camera.mean("direct"), camera.var("direct")),
               "combined": (light.mean("caustic") + camera.mean("fog_direct"),
                            light.var("caustic") + camera.var("fog_direct"))}
        out = {k: (m.astype(np.float32), v.astype(np.float32)) for k, (m, v) in out.items()}
        if self.orders is not None:  # the model term: what orders beyond the paper's model add
            terms = {c: (self.orders.mean(f"{c}_ms"), self.orders.var(f"{c}_ms")) for c in scattering.ORDER_COMPONENTS}
            terms["combined"] = (sum(m for m, _ in terms.values()), self.orders.var("combined_ms"))
            out.update({f"{c}_ms": (m.astype(np.float32), v.astype(np.float32)) for c, (m, v) in terms.items()})
        m = np.repeat(self.mask.astype(np.float32)[..., None], 3, axis=2)
        out[MASK_LAYER] = (m, np.zeros_like(m))
        return out

    def single(self) -> tuple:
        """({component: mean}, {component: var}) of the single-scattering streams."""
        light, camera = self.light, self.camera
        means = {"caustic": light.mean("caustic"), "fog": camera.mean("fog"), "direct": camera.mean("direct")}
        return means, {"caustic": light.var("caustic"), "fog": camera.var("fog"), "direct": camera.var("direct")}

    def convergence(self) -> dict | None:
        """The orders stream's convergence per component (orders.convergence), or None
        without it (or before every stream has two batches)."""
        if self.orders is None or min(s.n for s in self.streams().values()) < 2 or self.mask is None:
            return None
        return scattering.convergence(*self.single(), self.orders, ~self.mask)

    def total_variance_ratios(self) -> dict:
        """Colour layer → per channel, its total's variance over Σ of its pixels'
        (``batches.total_variance_ratio``; None before two batches)."""
        light, camera = (self.light, "caustic"), (self.camera, "fog_direct")
        parts = {"caustic": [light], "fog": [(self.camera, "fog")], "direct": [(self.camera, "direct")],
                 "combined": [light, camera]}
        if self.orders is not None:
            parts.update({name: [(self.orders, name)] for name in (*scattering.MODEL_FLOORS, "combined_ms")})
        return {name: total_variance_ratio(*p, keep=self.total_keep) for name, p in parts.items()}

    def floors(self) -> dict:
        """Noise floor per colour layer over the pixels that do not see glass (None
        without energy or without two batches yet)."""
        keep = ~self.mask if self.mask is not None else None
        out = {}
        for name, stats, image in (("caustic", self.light, "caustic"), ("fog", self.camera, "fog"),
                                   ("direct", self.camera, "direct")):
            out[name] = noise_floor(stats.mean(image), stats.var(image), keep) if stats.n >= 2 and keep is not None \
                else None
        if self.light.n >= 2 and self.camera.n >= 2 and keep is not None:
            mean = self.light.mean("caustic") + self.camera.mean("fog_direct")
            out["combined"] = noise_floor(mean, self.light.var("caustic") + self.camera.var("fog_direct"), keep)
        else:
            out["combined"] = None
        if self.orders is not None:
            ready = min(s.n for s in self.streams().values()) >= 2 and keep is not None
            out.update(scattering.model_floors(self.single()[0], self.orders, keep) if ready
                       else {f"{c}_ms": None for c in scattering.ORDER_COMPONENTS})
        return out


def _pending(state: RenderState, settings: ReferenceSettings, stream: str, floors: dict) -> bool:
    """Whether ``stream`` needs another batch: fewer than ``batches``, or (target_noise)
    a component of it above its target (``floors``: the state's) and the photon cap not
    reached."""
    stats = state.streams()[stream]
    if stats.n < settings.batches:
        return True
    targets = settings.targets()
    if not targets:
        return False
    if stream != CAMERA and settings.photon_cap_reached(stats.n * settings.photons_per_batch()):
        return False
    names = {LIGHT: ("caustic",), CAMERA: ("fog", "direct"), ORDERS: scattering.MODEL_FLOORS}[stream]
    return any(name in targets and floors[name] is not None and floors[name] > targets[name] for name in names)


def _stop_reason(state: RenderState, settings: ReferenceSettings, timed_out: bool) -> str:
    if not settings.targets():
        return "batches"
    floors, targets = state.floors(), settings.targets()
    if all(floors[name] is None or floors[name] <= target for name, target in targets.items()):
        return "target"
    return "time cap" if timed_out else "photon cap"


def _format_floors(floors: dict) -> str:
    return " ".join(f"{name} {100 * v:.2f}%" for name, v in floors.items() if v is not None and name != "combined")


def _render(request: RenderRequest, state: RenderState | None = None, *, progress: bool) -> tuple:
    """Render batches of both streams into ``state`` (a fresh one if None) until the
    settings are met (module docstring); returns (state, stopped_by, seconds of this call)."""
    from tqdm import tqdm

    from ..mi_setup import mitsuba
    from .export import load_scene
    from .integrators import SingleScatterIntegrator, VolumetricLightTracer, configure

    mi = mitsuba()
    scene, settings = request.scene, request.settings
    state = state or RenderState.for_settings(settings)
    t0 = time.perf_counter()
    mi_scene = load_scene(mi, request.description)
    tracer = configure(VolumetricLightTracer(_properties(mode=request.mode, max_scatter=1)), scene, mi_scene)
    camera = configure(SingleScatterIntegrator(), scene, mi_scene)
    higher = None
    if state.orders is not None:
        higher = configure(VolumetricLightTracer(_properties(mode="orders", max_scatter=settings.max_scatter,
                                                             beyond_model=True)), scene, mi_scene)
    photon_spp, camera_spp = settings.photon_spp_per_batch(), settings.camera_spp_per_batch()
    total = None if settings.targets() else sum(max(0, settings.batches - s.n) for s in state.streams().values())
    bar = tqdm(total=total, desc=f"reference {scene.name}", unit="batch", disable=not progress)
    timed_out = False
    floors = state.floors()
    while True:
        # the camera's batch first: its glass mask chooses the pixels of every stream's totals
        streams = sorted((s for s in state.streams() if _pending(state, settings, s, floors)),
                         key=lambda s: s != CAMERA)
        if not streams:
            break
        minimum = min(s.n for s in state.streams().values()) >= settings.batches  # caps apply beyond the minimum
        if settings.targets() and minimum and time.perf_counter() - t0 > settings.max_seconds:
            timed_out = True
            break
        for stream in streams:
            if stream == LIGHT:
                seed = batch_seed(settings.seed, LIGHT, state.light.n)
                image = _rendered(mi, mi_scene, tracer, seed, photon_spp)[..., :3]
                state.light.add({"caustic": image}, state.total_keep)
            elif stream == ORDERS:
                seed = batch_seed(settings.seed, ORDERS, state.orders.n)
                higher.prepare_orders(settings.width, settings.height)
                _rendered(mi, mi_scene, higher, seed, settings.orders_spp_per_batch())
                stack = higher.order_images()
                state.orders.add(scattering.batch_images(stack, settings.max_scatter), state.total_keep)
            else:
                seed = batch_seed(settings.seed, CAMERA, state.camera.n)
                cam = _rendered(mi, mi_scene, camera, seed, camera_spp)
                fog, direct = cam[..., 3:6], cam[..., 6:9]
                seen = cam[..., 9] > 0.5
                state.mask = seen if state.mask is None else state.mask | seen
                if state.total_keep is None:
                    state.total_keep = ~seen
                state.camera.add({"fog": fog, "direct": direct, "fog_direct": fog + direct}, state.total_keep)
            bar.update(1)
        floors = state.floors()
        state.note_targets(settings.targets(), floors, time.perf_counter() - t0)
        bar.set_postfix_str(_format_floors(floors))
    bar.close()
    seconds = time.perf_counter() - t0
    state.seconds += seconds
    return state, _stop_reason(state, settings, timed_out), seconds


def _properties(**values):
    from ..mi_setup import mitsuba

    props = mitsuba().Properties()
    for name, value in values.items():
        props[name] = value
    return props


def _rendered(mi, mi_scene, integrator, seed: int, spp: int) -> np.ndarray:
    """One batch as an array, rendered where an interrupt does not wait for it
    (``infra.interrupts.interruptible``: a batch can run for minutes, or forever)."""
    return interruptible(lambda: np.asarray(mi.render(mi_scene, integrator=integrator, seed=seed, spp=spp)))


def render_batches(scene, settings: ReferenceSettings, *, mode: str = "caustic", progress: bool = True) -> dict:
    """Render without the cache; returns {layer: (mean, var)} for the colour layers
    and the mask, plus timing, counts and noise floors under the key ``"_info"``."""
    request = resolve(scene, settings, mode)
    state, stopped_by, seconds = _render(request, progress=progress)
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


def _satisfied(manifest: dict, settings: ReferenceSettings) -> bool:
    """Whether a cached entry already meets ``settings``: its batches, or its floors
    below every target (or its photon cap reached)."""
    if manifest.get("batches", 0) < settings.batches or manifest.get("camera_batches", 0) < settings.batches:
        return False
    if settings.max_scatter > 1 and manifest.get("orders_batches", 0) < settings.batches:
        return False
    targets = settings.targets()
    floors = manifest.get("noise_floor", {})
    for name, target in targets.items():
        floor = floors.get(name)
        if floor is not None and floor > target:
            if name != "fog" and name != "direct" and settings.photon_cap_reached(manifest.get("photons", 0)):
                continue
            return False
    return True


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


def render_reference(scene, settings: ReferenceSettings | None = None, *, mode: str = "caustic",
                     force: bool = False, progress: bool = True) -> ReferenceResult:
    """The reference for ``scene``: from the cache when a valid entry meets ``settings``
    (and not ``force``); an entry that does not (fewer batches, a noise floor above
    ``target_noise``) is continued batch by batch, never thrown away; else rendered and
    stored. The image is ``settings.width × height`` (unset: the scene camera's).
    ``mode``: which light paths the caustic layer counts (settings.MODES)."""
    from ..mi_setup import drjit_version, mitsuba_version, variant_name

    request = resolve(scene, settings, mode)
    settings = request.settings
    key = cache.request_key(request, variant_name())
    state = None
    if not force:
        served = cache.lookup(request)
        if served is not None:
            served_key, manifest, layers = served
            if _satisfied(manifest, settings):
                return ReferenceResult(served_key, for_caller(manifest, scene), cached=True, layers=layers)
            if served_key == key:
                state = _resumable(cache.read_state(served_key, manifest), settings)
    cache.manifest_path(key, write=True)  # a render is stored: a read-only cache is refused before it, not after
    state, stopped_by, seconds = _render(request, state, progress=progress)
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
        "seconds_this_call": seconds, "mitsuba_variant": variant_name(), "mitsuba_version": mitsuba_version(),
        "drjit_version": drjit_version(), "reference_code_version": cache.code_version(),
    }
    header = {"volcaustics_scene": scene.name, "volcaustics_scene_hash": scene.scene_hash(),
              "volcaustics_renderer": "reference", "volcaustics_manifest": json.dumps(manifest, default=float)}
    manifest = cache.store(key, layers, manifest, header, png_bytes(tonemap_srgb8(layers["combined"])),
                           state=state.arrays())
    return ReferenceResult(key, manifest, cached=False, layers=layers)
