"""Photon splatting (paper §3, Eq. 5, §4.3): medium-collision photons as 3D
Gaussians, closed-form line integrals along pixel rays, additive float blending.

Accepts photon records from any source: the GPU tracer's record buffers, or
numpy arrays (for instance from the exact photon tracer) via :func:`raw_from_arrays`.
"""

from __future__ import annotations

import moderngl
import numpy as np

from .context import bound
from .glsl import attribute_layout, program
from .records import RAW_RECORD_DTYPE, STATUS_COLLIDED

# Instance attributes read from a raw record (96 bytes): dir_t @16, end_status @48, power_inside @64.
INSTANCE_PARTS = [("16x", None), ("4f", "in_dir_t"), ("16x", None), ("4f", "in_end"), ("4f", "in_power"), ("16x", None)]


def raw_from_arrays(end, direction, power, status=None) -> np.ndarray:
    """Raw records for the splatter from numpy arrays: end (N×3 collision points, m),
    direction (N×3 unit, propagation before scattering), power (N×3 W, RGB, after
    transmittance), status (N, default all collided)."""
    end = np.asarray(end, np.float32).reshape(-1, 3)
    raw = np.zeros(len(end), dtype=RAW_RECORD_DTYPE)
    raw["dir_t"][:, :3] = np.asarray(direction, np.float32).reshape(-1, 3)
    raw["end_status"][:, :3] = end
    raw["end_status"][:, 3] = STATUS_COLLIDED if status is None else np.asarray(status)
    raw["power_inside"][:, :3] = np.asarray(power, np.float32).reshape(-1, 3)
    return raw


class Splatter:
    """Splat program for one phase function."""

    def __init__(self, ctx: moderngl.Context, medium):
        self.ctx = ctx
        phase = {"PHASE_G": repr(float(medium.phase.g))} if medium.phase.kind == "hg" else {}
        self.program = program(ctx, "splat/splat.vert.glsl", "splat/splat.frag.glsl", phase)
        corners = np.array([[-1, -1], [1, -1], [-1, 1], [1, 1]], np.float32)
        self.corners = ctx.buffer(corners.tobytes())

    def splat(self, records: moderngl.Buffer, count: int, view, medium, splat_radius: float, sigma_bar: float,
              scene_distance: moderngl.Texture, target: moderngl.Texture) -> None:
        """Add the collided photons of one record buffer into ``target`` (RGBA32F)."""
        if count == 0 or sigma_bar <= 0:
            return
        ctx, prog = self.ctx, self.program
        view.set_uniforms(prog)
        prog["scatter_weight"].value = tuple(s / sigma_bar for s in medium.sigma_s)
        prog["sigma_t"].value = tuple(medium.sigma_t)
        prog["sigma"].value = float(splat_radius)
        scene_distance.use(location=0)
        prog["scene_distance"].value = 0
        fmt, names = attribute_layout(prog, INSTANCE_PARTS, per_instance=True)
        vao = ctx.vertex_array(prog, [(self.corners, "2f", "in_corner"), (records, fmt, *names)])
        fbo = ctx.framebuffer(color_attachments=[target])
        with bound(ctx, fbo):
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.ONE, moderngl.ONE
            ctx.blend_equation = moderngl.FUNC_ADD
            vao.render(moderngl.TRIANGLE_STRIP, vertices=4, instances=count)
            ctx.disable(moderngl.BLEND)
        fbo.release()
        vao.release()

    def release(self):
        self.program.release()
        self.corners.release()
