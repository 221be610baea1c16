"""What a reference render has so far: the batch statistics of its streams, the glass mask,
the seconds spent, and from them the layers, the noise floors and whether a stream needs
another batch (``reference.render`` drives it, the cache stores it)."""

from __future__ import annotations

import json
from typing import cast

import numpy as np

from volcaustics.scenes.formats import MASK_LAYER

from ..settings import ReferenceSettings
from . import orders as scattering
from .batches import (
    CAMERA,
    LIGHT,
    LIGHT_GROUPS,
    ORDERS,
    STREAM_IMAGES,
    BatchStats,
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
            terms["combined"] = (cast(np.ndarray, sum(m for m, _ in terms.values())), self.orders.var("combined_ms"))
            out.update({f"{c}_ms": (m.astype(np.float32), v.astype(np.float32)) for c, (m, v) in terms.items()})
        m = np.repeat(cast(np.ndarray, self.mask).astype(np.float32)[..., None], 3, axis=2)  # set by the first batch
        out[MASK_LAYER] = (m, np.zeros_like(m))
        return out

    def single(self) -> tuple[dict, dict]:
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
            out.update(scattering.model_floors(self.single()[0], self.orders, cast(np.ndarray, keep)) if ready
                       else {f"{c}_ms": None for c in scattering.ORDER_COMPONENTS})
        return out


def stream_pending(state: RenderState, settings: ReferenceSettings, stream: str, floors: dict) -> bool:
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


def stop_reason(state: RenderState, settings: ReferenceSettings, timed_out: bool) -> str:
    if not settings.targets():
        return "batches"
    floors, targets = state.floors(), settings.targets()
    if all(floors[name] is None or floors[name] <= target for name, target in targets.items()):
        return "target"
    return "time cap" if timed_out else "photon cap"


def format_floors(floors: dict) -> str:
    return " ".join(f"{name} {100 * v:.2f}%" for name, v in floors.items() if v is not None and name != "combined")
