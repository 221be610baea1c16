"""One batch of a reference as a task: rendered where it runs (this process, a local
worker process, a Dask worker on another machine) and added to the render's state in
the process that keeps it, in batch order.

A batch is independent of every other (its seed is ``batches.batch_seed`` of the
settings' seed, its stream and its index), so where it renders changes nothing but
the float32 rounding of splats that race: the light tracer adds its photons into the
film with atomic adds, and with more than one Dr.Jit thread their order varies from run
to run. With one thread a batch is the same bytes on every run and every worker
(docs/decisions.md "Reference batches on workers").

:func:`render_batch` renders (the worker's side: plain data in, arrays out);
:func:`add_batch` adds (the state's side). The sources (``reference.render.sources``)
decide where :func:`render_batch` runs.
"""

from __future__ import annotations

import os
import socket
import threading
import time
from collections import OrderedDict
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.infra.interrupts import interruptible

from . import orders as scattering
from .batches import CAMERA, LIGHT, ORDERS, batch_seed

if TYPE_CHECKING:
    from ..request import RenderRequest
    from .state import RenderState

# GL contexts and Mitsuba belong to a process: a worker with more than one thread (a Dask
# worker started without --nthreads 1) runs its batches and points one at a time
PROCESS_LOCK = threading.RLock()
# Mitsuba scenes and integrators kept per process, by reference key: the scene is loaded
# and the kernels are compiled once per worker, not once per batch; the last two are kept
_PREPARED: OrderedDict = OrderedDict()
_KEEP = 2


def render_batch(key: str, request: RenderRequest, stream: str, index: int) -> tuple:
    """(images, seconds, where) of batch ``index`` of ``stream`` (LIGHT, ORDERS or CAMERA) of
    ``request`` (a ``reference.request.RenderRequest``; ``key``: its cache key, naming
    the Mitsuba scene this process keeps for it). ``seconds`` includes loading that
    scene when this is the process's first batch of it; ``where`` is :func:`process_name`."""
    with PROCESS_LOCK:
        t0 = time.perf_counter()
        mi, mi_scene, integrators = _prepared(key, request)
        settings = request.settings
        seed = batch_seed(settings.seed, stream, index)
        integrator = integrators[stream]
        if stream == LIGHT:
            images = {"caustic": _rendered(mi, mi_scene, integrator, seed, settings.photon_spp_per_batch())[..., :3]}
        elif stream == ORDERS:
            integrator.prepare_orders(settings.width, settings.height)
            _rendered(mi, mi_scene, integrator, seed, settings.orders_spp_per_batch())
            images = scattering.batch_images(integrator.order_images(), settings.max_scatter)
        else:
            cam = _rendered(mi, mi_scene, integrator, seed, settings.camera_spp_per_batch())
            images = {"fog": cam[..., 3:6], "direct": cam[..., 6:9], "seen": cam[..., 9] > 0.5}
        return images, time.perf_counter() - t0, process_name()


def process_name() -> str:
    """``host:pid`` of this process: where a batch rendered (a reference's ``rendered_by``)."""
    return f"{socket.gethostname()}:{os.getpid()}"


def add_batch(state: RenderState, stream: str, images: dict) -> None:
    """Add one batch's ``images`` (:func:`render_batch`) to ``state`` (a RenderState). The
    camera's glass mask grows with each of its batches, and its first batch fixes the
    pixels of every stream's totals (the camera's batch of a round is added first)."""
    if stream == CAMERA:
        fog, direct, seen = images["fog"], images["direct"], images["seen"]
        state.mask = seen if state.mask is None else state.mask | seen
        if state.total_keep is None:
            state.total_keep = ~seen
        state.camera.add({"fog": fog, "direct": direct, "fog_direct": fog + direct}, state.total_keep)
    else:
        state.streams()[stream].add(images, state.total_keep)


def forget(key: str) -> None:
    """Drop the Mitsuba scene this process keeps for ``key`` (its render is done)."""
    _PREPARED.pop(key, None)


def _prepared(key: str, request) -> tuple:
    """(mitsuba, scene, {stream: integrator}) for ``request``, loaded once per process."""
    if key in _PREPARED:
        _PREPARED.move_to_end(key)
        return _PREPARED[key]
    from ..mi_setup import mitsuba
    from .camera_integrator import SingleScatterIntegrator
    from .export import load_scene
    from .integrators import VolumetricLightTracer, configure

    mi = mitsuba()
    scene, settings = request.scene, request.settings
    mi_scene = load_scene(mi, request.description)
    integrators = {LIGHT: configure(VolumetricLightTracer(_properties(mode=request.mode, max_scatter=1)), scene,
                                    mi_scene),
                   CAMERA: configure(SingleScatterIntegrator(), scene, mi_scene)}
    if settings.max_scatter > 1:
        integrators[ORDERS] = configure(VolumetricLightTracer(_properties(
            mode="orders", max_scatter=settings.max_scatter, beyond_model=True)), scene, mi_scene)
    _PREPARED[key] = (mi, mi_scene, integrators)
    while len(_PREPARED) > _KEEP:
        _PREPARED.popitem(last=False)
    return _PREPARED[key]


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
