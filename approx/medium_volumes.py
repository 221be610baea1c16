"""A heterogeneous medium on the GPU: its density grid, its majorants and the two
transmittance volumes the approximation reads instead of the exact transmittance.

* the density grid (``scenes.density``) and its coarse majorants, as storage buffers
  (``common/density.glsl`` reads them with the trilinear interpolation written out: the
  photons' delta tracking and σs(x) in the fog);
* the **light volume**: the optical depth of ρ from the spot light along the ray through
  each of ``light_volume_res``² texels of its frustum, at ``light_volume_slices``
  distances (a light-space transmittance map, a renderer's volumetric shadow map): the
  light's side of the fog and of direct light;
* the **camera volume**: the same from the eye through ``camera_volume_res``² texels of the
  camera's view (a froxel volume, Hillaire 2015): the eye's side of the fog, of direct light
  and of every splat.

Both are made by ``medium/depth_volume.comp.glsl`` once per frame, before the passes that
read them (no read-back: a display frame's pass). A homogeneous medium has none of them
and its programs none of this code (:func:`medium_defines`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import moderngl
import numpy as np

from volcaustics.scenes.density import MAJORANT_BLOCK
from volcaustics.scenes.medium_grid import density_grid

from .glsl import compute_shader, set_uniforms, uniform
from .transforms import gl_matrix

if TYPE_CHECKING:
    from volcaustics.scenes.model import Medium, Scene

    from .light import LightFrustum
    from .params import ApproxParams
    from .resources import FrameResources

DENSITY_BINDING, MAJORANT_BINDING = 11, 12   # storage buffers (common/density.glsl's defaults)
EYE_KNOTS_BINDING = 13                        # ... and beams' eye knots (splat/eye_knots.glsl's default)
# EXACT_EYE's knots per pixel: up to 32 (a fragment walks ~1/32 of its ray's cell planes; the whole
# walk per fragment took 37 of a smoke closure case's 165 s at 256² fine pixels, docs/decisions.md
# "Heterogeneous media"), fewer where the view's pixels would take more than 2^24 floats (64 MB)
EYE_KNOTS_MAX, EYE_KNOT_FLOATS = 32, 1 << 24
LIGHT_VOLUME_UNIT, CAMERA_VOLUME_UNIT = 5, 6  # texture units of the volumes (common/volumes.glsl)


def medium_defines(medium: Medium) -> dict:
    """The #defines a program of the frame gets for ``medium``: HETEROGENEOUS when a density
    grid scales it (the program reads the grid and the volumes), none otherwise."""
    return {"HETEROGENEOUS": 1} if medium.is_heterogeneous else {}


def eye_knot_count(width: int, height: int) -> int:
    """EXACT_EYE's knots per pixel of a ``width``×``height`` view (splat/eye_knots.glsl)."""
    return max(1, min(EYE_KNOTS_MAX, EYE_KNOT_FLOATS // (width * height)))


def _far(origin: np.ndarray, box: tuple[np.ndarray, np.ndarray]) -> float:
    """The distance from ``origin`` to the farthest corner of ``box``."""
    corners = np.array([[x, y, z] for x in (box[0][0], box[1][0]) for y in (box[0][1], box[1][1])
                        for z in (box[0][2], box[1][2])])
    return max(float(np.linalg.norm(corners - origin, axis=1).max()), 1e-3)


class MediumVolumes:
    """The density grid's buffers and the light and camera volumes of one frame."""

    def __init__(self, ctx: moderngl.Context, pool: FrameResources):
        self.ctx, self.pool = ctx, pool
        self.builder = compute_shader(ctx, "medium/depth_volume.comp.glsl")
        pool.track(self.builder)
        self.uniforms: dict = {}
        self._grid_key: object = None
        self.eye_builder: moderngl.ComputeShader | None = None  # EXACT_EYE's knots, compiled when first used
        self._eye_key: object = None
        self._eye_grid: object = None

    def update(self, scene: Scene, frustum: LightFrustum, eye: np.ndarray, view_proj: np.ndarray,
               box: tuple[np.ndarray, np.ndarray], params: ApproxParams) -> None:
        """Upload ``scene``'s density grid (when it changed) and make this frame's volumes: the
        light's through ``frustum``, the camera's from ``eye`` through the view ``view_proj``
        (4×4 world → clip)."""
        grid = density_grid(scene)
        assert grid is not None, "MediumVolumes needs a heterogeneous medium"
        if self._grid_key is not grid:
            self.density = self.pool.buffer("density_values", grid.values.nbytes)
            self.density.write(np.ascontiguousarray(grid.values, np.float32).tobytes())
            majorants = grid.majorants(MAJORANT_BLOCK)
            self.majorants = self.pool.buffer("density_majorants", majorants.nbytes)
            self.majorants.write(majorants.tobytes())
            self._grid_key = grid
            self.uniforms = {"density_res": grid.resolution, "density_min": tuple(grid.lo),
                             "density_max": tuple(grid.hi), "majorant_res": tuple(reversed(majorants.shape)),
                             "majorant_block": MAJORANT_BLOCK}
        self.bind_grid(self.builder)
        self.light = self._volume("light_volume", frustum.position, frustum.view_proj, params.light_volume_res,
                                  params.light_volume_slices, box)
        self.camera = self._volume("camera_volume", eye, view_proj, params.camera_volume_res,
                                   params.camera_volume_slices, box)

    def _volume(self, name: str, origin: np.ndarray, view_proj: np.ndarray, res: int, slices: int,
                box: tuple[np.ndarray, np.ndarray]) -> dict:
        origin = np.asarray(origin, np.float64)
        texture = self.pool.texture3d(name, (res, res, slices))
        distance = _far(origin, box)
        prog = self.builder
        set_uniforms(prog, origin=tuple(origin), columns=(res, res), max_distance=distance, slices=slices)
        uniform(prog, "inv_view_proj").write(gl_matrix(np.linalg.inv(view_proj)))
        texture.bind_to_image(0, read=False, write=True)
        prog.run(-(-res // 8), -(-res // 8), 1)
        return {"texture": texture, "view_proj": view_proj, "origin": tuple(origin), "distance": distance,
                "slices": slices}

    def bind_eye_knots(self, prog: moderngl.Program, eye: np.ndarray, view_proj: np.ndarray,
                       size: tuple[int, int]) -> None:
        """Give ``prog`` (a beam program under EXACT_EYE) the eye knots of the view from ``eye``
        through ``view_proj`` (4×4 world → clip) at ``size`` (width, height) pixels: per pixel the
        exact depth from the eye along its ray at :func:`eye_knot_count` distances
        (splat/eye_knots.comp.glsl), made when the view or the grid changed."""
        width, height = size
        count = eye_knot_count(width, height)
        reach = _far(eye, (np.asarray(self.uniforms["density_min"]), np.asarray(self.uniforms["density_max"])))
        key = (width, height, count, np.asarray(eye, np.float64).tobytes(), np.asarray(view_proj).tobytes())
        self.eye_knots = self.pool.buffer("eye_knots", 4 * count * width * height)
        self.eye_knots.bind_to_storage_buffer(EYE_KNOTS_BINDING)
        if self._eye_key != key or self._eye_grid is not self._grid_key:
            if self.eye_builder is None:
                self.eye_builder = compute_shader(self.ctx, "splat/eye_knots.comp.glsl")
                self.pool.track(self.eye_builder)
            builder = self.eye_builder
            self.bind_grid(builder)
            uniform(builder, "view_proj").write(gl_matrix(view_proj))
            set_uniforms(builder, eye=tuple(float(v) for v in eye), viewport=(float(width), float(height)),
                         eye_knot_count=count, eye_reach=reach)
            builder.run(-(-width // 8), -(-height // 8), 1)
            self.ctx.memory_barrier()
            self._eye_key, self._eye_grid = key, self._grid_key
        set_uniforms(prog, eye_knot_count=count, eye_reach=reach)

    def bind_grid(self, prog: moderngl.Program | moderngl.ComputeShader) -> None:
        """Give ``prog`` the density grid and its majorants (storage buffers and uniforms)."""
        self.density.bind_to_storage_buffer(DENSITY_BINDING)
        self.majorants.bind_to_storage_buffer(MAJORANT_BINDING)
        set_uniforms(prog, **self.uniforms)

    def bind(self, prog: moderngl.Program | moderngl.ComputeShader, march_steps: int | None = None) -> None:
        """Give ``prog`` the grid, the volumes (texture units :data:`LIGHT_VOLUME_UNIT`,
        :data:`CAMERA_VOLUME_UNIT`) and ``march_steps``, whichever of them it reads."""
        self.ctx.memory_barrier()  # the volumes' image stores before any read
        self.bind_grid(prog)
        for which, unit in (("light", LIGHT_VOLUME_UNIT), ("camera", CAMERA_VOLUME_UNIT)):
            volume = getattr(self, which)
            volume["texture"].use(location=unit)
            set_uniforms(prog, **{f"{which}_volume": unit, f"{which}_volume_origin": volume["origin"],
                                  f"{which}_volume_distance": volume["distance"],
                                  f"{which}_slices": volume["slices"]})
            if f"{which}_volume_view_proj" in prog:
                uniform(prog, f"{which}_volume_view_proj").write(gl_matrix(volume["view_proj"]))
        if march_steps is not None:
            set_uniforms(prog, march_steps=march_steps)
