"""A quick rasterised preview of a scene from its camera (not physically based).

For checking geometry, framing and the light cone before any real rendering:
diffuse surfaces in their albedo, specular objects in a light blue, lit by the
spot light (Lambert, inverse square, inside the cutoff cone, no shadows) plus a
dim headlight.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import moderngl
import numpy as np

from .context import bound
from .geometry import bind_identity_models
from .glsl import program, uniform
from .transforms import gl_matrix, look_at, perspective

if TYPE_CHECKING:
    from volcaustics.scenes.mesh import Mesh
    from volcaustics.scenes.model import DiffuseSurface, Scene, SpecularObject

SPECULAR_PREVIEW_ALBEDO = (0.55, 0.75, 0.95)


def flat_triangles(mesh: Mesh) -> np.ndarray:
    """Interleaved (position, face normal) vertices, (3·F)×6 float32, world space."""
    tri = mesh.vertices[mesh.faces]  # F×3×3
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    data = np.concatenate([tri, np.repeat(normal[:, None, :], 3, axis=1)], axis=2)
    return data.reshape(-1, 6).astype(np.float32)


def scene_extent(scene: Scene) -> float:
    """Distance from the camera to the farthest object vertex (m), for the far plane."""
    eye = np.asarray(scene.camera.position)
    far = 1.0
    objects: tuple[SpecularObject | DiffuseSurface, ...] = (*scene.specular, *scene.diffuse)
    for obj in objects:
        far = max(far, float(np.linalg.norm(obj.mesh.load().vertices - eye, axis=1).max()))
    return far


PREVIEW_STAGES = ("camera/gbuffer.vert.glsl", "preview/preview.frag.glsl")  # the G-buffer's vertex stage, no defines


def render_preview(ctx: moderngl.Context, scene: Scene, width: int | None = None,
                   height: int | None = None) -> np.ndarray:
    """Preview image, H×W×3 float32, linear, >= 0, row 0 at the top."""
    cam, light = scene.camera, scene.light
    width, height = width or cam.width, height or cam.height
    prog = program(ctx, *PREVIEW_STAGES)
    view = look_at(cam.position, cam.target, cam.up)
    proj = perspective(cam.fov_y, width / height, 0.01, 2.0 * scene_extent(scene))
    uniform(prog, "view_proj").write(gl_matrix(proj @ view))
    uniform(prog, "eye").value = tuple(cam.position)
    uniform(prog, "light_position").value = tuple(light.position)
    uniform(prog, "light_direction").value = tuple(light.direction)
    uniform(prog, "cos_cutoff").value = math.cos(math.radians(light.cutoff_angle))
    uniform(prog, "intensity").value = tuple(light.intensity)
    uniform(prog, "headlight").value = 0.15 * float(max(light.intensity)) / max(float(np.linalg.norm(
        np.subtract(light.position, cam.target))), 1e-3) ** 2

    color = ctx.texture((width, height), 4, dtype="f4")
    depth = ctx.depth_renderbuffer((width, height))
    fbo = ctx.framebuffer(color_attachments=[color], depth_attachment=depth)
    objects = [(o.mesh, o.albedo) for o in scene.diffuse] + [(o.mesh, SPECULAR_PREVIEW_ALBEDO) for o in scene.specular]
    resources: list = [bind_identity_models(ctx, prog)]  # the vertices below are in world space
    with bound(ctx, fbo):
        ctx.enable(moderngl.DEPTH_TEST)
        fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        for spec, albedo in objects:
            vbo = ctx.buffer(flat_triangles(spec.load()).tobytes())
            vao = ctx.vertex_array(prog, [(vbo, "3f 3f", "in_position", "in_normal")])
            uniform(prog, "albedo").value = tuple(albedo)
            vao.render(moderngl.TRIANGLES)
            resources += [vao, vbo]
        ctx.disable(moderngl.DEPTH_TEST)
        image = np.frombuffer(fbo.read(components=3, dtype="f4"), dtype=np.float32).reshape(height, width, 3)
    image = np.ascontiguousarray(image[::-1])  # GL rows start at the bottom
    for r in (*resources, fbo, color, depth, prog):
        r.release()
    return image
