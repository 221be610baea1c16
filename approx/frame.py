"""What a frame of the approximation is: :class:`FramePasses` (what its passes leave on the
GPU), :class:`Frame` (the measured frame on the host: images, records, times and counts) and
the helpers that read and compose it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple, cast

import moderngl
import numpy as np

from volcaustics.scenes.formats import KIND_SPECULAR

from .camera_pass import CameraView

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

    from .params import ApproxParams
    from .trace import PhotonTracer


@dataclass
class Frame:
    """One rendered frame.

    images: layer name (``scenes.formats.LAYER_NAMES``) → H×W×3 float32, linear Rec.709,
        radiance W·m⁻²·sr⁻¹, row 0 at the top (``mask_specular`` is 0/1 in all three channels).
    caustic_steps: per interaction step, the caustic image of that step's photons.
    records: per step, the segment records (scenes.formats.RECORD_DTYPE, active photons).
    timings: pass name → seconds; ``timing_method`` says how they were measured.
    work: what ``approx.cost`` counts beside the records: ``fragments`` and ``primitives``
        (pass name → fragments written, GL samples passed, and primitives drawn, summed
        over its steps; 0 for a compute pass), ``shaded`` (pass name → fragments shaded,
        discards included, where the driver counts them: ``approx.invocations``),
        ``lookups`` and ``lockstep_lookups`` (the trace loop's map lookups over every
        step: the photons' own, and their subgroups' in lockstep, ``Tracer.loop_work``),
        ``medium_reads`` (the trace's samples of a heterogeneous medium's ρ, 0 in a
        homogeneous one) and ``heterogeneous`` (whether the medium has a density grid).
    params: the parameters actually used (width/height resolved).
    guides: the G-buffer a temporal filter or denoiser reads: ``distance`` (H×W, to the
        eye, 0 where nothing is hit) and ``normal`` (H×W×3, world).
    """

    images: dict
    caustic_steps: list
    records: list
    timings: dict
    timing_method: str
    params: dict
    photons_emitted: int | None
    gl: dict = field(default_factory=dict)
    guides: dict = field(default_factory=dict)
    work: dict = field(default_factory=dict)


class FramePasses(NamedTuple):
    """What one frame's passes leave on the GPU (the renderer's pool): the tracer that ran,
    per step its caustic image, the records buffer (each step ``record_stride`` bytes on,
    or all in one range: stride 0), the kernel differentials per step (or None), the
    G-buffer, the fog and direct images, the caustic and the composed frame."""

    tracer: PhotonTracer
    steps: list
    records: moderngl.Buffer
    kernels: moderngl.Buffer | None
    record_stride: int
    gbuffer_geometry: moderngl.Texture
    gbuffer_normal: moderngl.Texture
    fog: moderngl.Texture
    direct: moderngl.Texture
    caustic: moderngl.Texture
    combined: moderngl.Texture


def read_rgb(tex: moderngl.Texture) -> np.ndarray:
    """An RGBA32F image as H×W×3 float32, row 0 at the top (reads it: waits for the GPU)."""
    w, h = tex.size
    rgba = np.frombuffer(tex.read(), dtype=np.float32).reshape(h, w, 4)
    return np.ascontiguousarray(rgba[::-1, :, :3])


def image_size(p: ApproxParams) -> tuple[int, int]:
    """(width, height) of resolved parameters (``ApproxParams.resolved``: both set)."""
    return cast(int, p.width), cast(int, p.height)


def compose(caustic_steps: list, fog: np.ndarray, direct: np.ndarray, gbuffer: np.ndarray, p: ApproxParams) -> dict:
    """The frame's layers (``scenes.formats.LAYER_NAMES``) from the passes' images, summed
    left to right in float32 as ``CameraPasses.compose`` adds them on the GPU."""
    caustic = (np.sum(caustic_steps, axis=0).astype(np.float32) if caustic_steps
               else np.zeros((*image_size(p)[::-1], 3), np.float32))
    kind = gbuffer[:, :, 1]
    mask = np.repeat((np.round(kind) == KIND_SPECULAR).astype(np.float32)[:, :, None], 3, axis=2)
    return {"caustic": caustic, "fog": fog, "direct": direct, "combined": caustic + fog + direct,
            "mask_specular": mask}


def camera_view(scene: Scene, p: ApproxParams, box: tuple[np.ndarray, np.ndarray]) -> CameraView:
    """The camera of a frame at the resolved image size; the far plane beyond the medium's box."""
    return CameraView(scene.camera, *image_size(p), far=2.0 * float(np.linalg.norm(box[1] - box[0])))
