"""What a frame needs against what the GL driver and this machine give: buffers by
photon_res and light_res against the memory budget, dispatch sizes against the driver's
work-group limit, image sides against its largest texture, checked before any GL work."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from volcaustics.infra.memory import image_fits, memory_budget
from volcaustics.scenes.formats import PHOTON_DTYPE, RAW_RECORD_DTYPE, RECORD_DTYPE, SPLAT_DTYPE

from .params import ParamError

if TYPE_CHECKING:
    from .params import ApproxParams

# The approximation's image buffers per pixel (G-buffer, fog, direct, per-step caustic
# targets and their read-backs): 264 B measured as peak RSS per pixel, rounded up
# (bench/image_memory.py, docs/decisions.md "Image sizes against memory").
IMAGE_BYTES_PER_PIXEL = 300
# The light maps' bytes per texel of one map, from what is allocated (not measured): the
# RGBA32F map 16, its geometric target 8 (16 with the id rule's primitive ids), the depth
# renderbuffer 4, the packed texel, distance, geometric and primitive buffers 16 + 4 + 8 + 4,
# the min-max pyramid 8 · 4/3: 71, rounded up.
LIGHT_MAP_BYTES_PER_TEXEL = 80


def check_fits(params: ApproxParams, *, keep_records: bool = False, max_groups: int | None = None,
               max_size: int | None = None, supersample: int = 1) -> None:
    """Raise ParamError, before any GL work, when ``params`` need buffers beyond
    :func:`memory_budget` (photon, record and splat buffers, and with ``keep_records``
    every step's records read back: photon_res 8192 asked for 7.5 GB of records), or more
    compute work groups in one dispatch than the GL driver runs (``max_groups``,
    GL_MAX_COMPUTE_WORK_GROUP_COUNT; 65,535 on Mesa: the dispatch would silently do
    nothing), or, with width and height set, an image the driver cannot draw or this
    machine cannot hold (:func:`check_image_fits`; ``supersample``: pixels per side of
    the largest image drawn, 4 for the measurement's small-kernel image). ``max_groups``
    and ``max_size`` default to the process's shared context's. Commands that render
    references first call this before them, so a frame that cannot run fails at once."""
    if max_groups is None:
        max_groups = gl_limits()[0]
    # the largest photon_res and light_res one dispatch runs: a size suggested for memory stays within it
    batches = params.fresnel_splits + 1  # photon_res² slots each (scenes.splitting)
    dispatchable = {"photon_res": math.isqrt(max_groups * 64 // batches), "light_res": math.isqrt(max_groups * 256)}
    need = batches * frame_bytes(params.photon_res, params.steps, keep_records=keep_records)
    budget = memory_budget()
    if need > budget:
        fits = min(math.isqrt(int(budget / (batches * frame_bytes(1, params.steps, keep_records=keep_records)))),
                   dispatchable["photon_res"])
        raise ParamError(f"photon_res = {params.photon_res}: a frame needs {need / 2**30:.1f} GiB of photon, "
                         f"record and splat buffers{' and records read back' if keep_records else ''}, more than "
                         f"half of this machine's memory ({budget / 2**30:.1f} GiB); photon_res ≤ {fits} fits")
    maps = light_map_bytes(params.light_res, params.layers)
    if maps > budget - need:
        fits = min(math.isqrt(int(max(budget - need, 0) / light_map_bytes(1, params.layers))),
                   dispatchable["light_res"])
        raise ParamError(f"light_res = {params.light_res}: {2 * params.layers} light maps (layers = "
                         f"{params.layers}) need {maps / 2**30:.1f} GiB beside the frame's "
                         f"{need / 2**30:.1f} GiB, more than half of this machine's memory "
                         f"({budget / 2**30:.1f} GiB); light_res ≤ {fits} fits")
    for name, res, per_group, copies in (("photon_res", params.photon_res, 64, batches),
                                         ("light_res", params.light_res, 256, 1)):
        if math.ceil(copies * res * res / per_group) > max_groups:
            limit = dispatchable[name]
            raise ParamError(f"{name} = {res}: this GL driver runs at most {max_groups} work groups of "
                             f"{per_group} in one dispatch, so {name} must be at most {limit}")
    if params.width is not None and params.height is not None:
        check_image_fits(params.width, params.height, max_size=max_size, supersample=supersample)


def check_image_fits(width: int, height: int, *, max_size: int | None = None, supersample: int = 1) -> None:
    """ParamError when an image of width × height pixels, drawn at up to ``supersample``
    pixels per side (a splat-only image: ``Renderer.splat``), exceeds the GL driver's
    largest texture and viewport (``max_size``, the least of GL_MAX_TEXTURE_SIZE and
    GL_MAX_VIEWPORT_DIMS; default the shared context's), or a frame's image buffers
    (IMAGE_BYTES_PER_PIXEL per pixel) exceed :func:`memory_budget`."""
    max_size = gl_limits()[1] if max_size is None else max_size
    drawn = "the image" if supersample == 1 else f"the image drawn at {supersample}× per side"
    for name, size in (("width", width), ("height", height)):
        if size * supersample > max_size:
            raise ParamError(f"{name} = {size}: {drawn} is {size * supersample} pixels, beyond this GL driver's "
                             f"largest texture and viewport ({max_size}); {name} ≤ {max_size // supersample} fits")
    reason = image_fits(width, height, IMAGE_BYTES_PER_PIXEL, "the approximation's image buffers")
    if reason:
        raise ParamError(reason)


def gl_limits() -> tuple:
    """(GL_MAX_COMPUTE_WORK_GROUP_COUNT in x, the largest image side: the least of
    GL_MAX_TEXTURE_SIZE and GL_MAX_VIEWPORT_DIMS) of the process's shared context."""
    from .context import shared_context

    info = shared_context().info
    return int(info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"][0]), max_image_size(info)


def max_image_size(info: dict[str, Any]) -> int:
    return int(min(info["GL_MAX_TEXTURE_SIZE"], *info["GL_MAX_VIEWPORT_DIMS"]))


def light_map_bytes(light_res: int, layers: int) -> int:
    """Bytes of the 2·layers light maps at light_res² and what is built from them
    (LIGHT_MAP_BYTES_PER_TEXEL)."""
    return 2 * layers * light_res * light_res * LIGHT_MAP_BYTES_PER_TEXEL


def frame_bytes(photon_res: int, steps: int, *, keep_records: bool = False) -> int:
    """Bytes a frame allocates per photon_res: photon, raw record and splat buffers (one
    slot per photon), and with ``keep_records`` each step's records read back (raw and
    converted)."""
    per_photon = PHOTON_DTYPE.itemsize + RAW_RECORD_DTYPE.itemsize + SPLAT_DTYPE.itemsize
    if keep_records:
        per_photon += steps * (RAW_RECORD_DTYPE.itemsize + RECORD_DTYPE.itemsize)
    return photon_res * photon_res * per_photon


