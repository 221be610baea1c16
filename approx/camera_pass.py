"""Camera passes: the G-buffer of primary hits, fog and direct lighting."""

from __future__ import annotations

from typing import TYPE_CHECKING

import moderngl
import numpy as np

from volcaustics.scenes.formats import KIND_DIFFUSE, KIND_SPECULAR

from .context import bound
from .glsl import program, uniform
from .glsl import set_uniforms as _set
from .light import spot_constants
from .transforms import gl_matrix, look_at, perspective

if TYPE_CHECKING:
    from volcaustics.scenes.model import Medium, Scene

    from .geometry import SceneGeometry
    from .light import LightFrustum

MAX_DIFFUSE = 16


class CameraView:
    """Camera matrices for one image size (GL conventions)."""

    def __init__(self, camera, width: int, height: int, far: float):
        self.eye = np.asarray(camera.position, np.float64)
        self.width, self.height = width, height
        self.view = look_at(camera.position, camera.target, camera.up)
        self.proj = perspective(camera.fov_y, width / height, 1e-3, far)
        self.view_proj = self.proj @ self.view
        self.inv_view_proj = np.linalg.inv(self.view_proj)

    def set_uniforms(self, prog: moderngl.Program) -> None:
        for name, value in (("eye", tuple(self.eye)), ("viewport", (float(self.width), float(self.height)))):
            if name in prog:
                uniform(prog, name).value = value
        for name, m in (("view_proj", self.view_proj), ("inv_view_proj", self.inv_view_proj)):
            if name in prog:
                uniform(prog, name).write(gl_matrix(m))


class CameraPasses:
    """G-buffer, fog and direct programs for one setting of the fog program's defines
    (``approx.params.defines(params, "fog")``: FOG_STEPS) and the phase function."""

    @staticmethod
    def programs(medium: Medium, fog_defines: dict) -> dict:
        """name → (shader stages, defines) of the camera passes' programs: the
        constructor's list and the shader check's (scripts/check_shaders.py)."""
        phase = {"PHASE_G": repr(float(medium.phase.g))} if medium.phase.kind == "hg" else {}
        return {"gbuffer": (("camera/gbuffer.vert.glsl", "camera/gbuffer.frag.glsl"), {}),
                "fog": (("shade/fullscreen.vert.glsl", "shade/fog.frag.glsl"), {**fog_defines, **phase}),
                "direct": (("shade/fullscreen.vert.glsl", "shade/direct.frag.glsl"), {"MAX_DIFFUSE": MAX_DIFFUSE})}

    def __init__(self, ctx: moderngl.Context, scene, fog_defines: dict):
        self.ctx = ctx
        programs = {name: program(ctx, stages[0], stages[1], defines)
                    for name, (stages, defines) in self.programs(scene.medium, fog_defines).items()}
        self.gbuffer, self.fog, self.direct = programs["gbuffer"], programs["fog"], programs["direct"]
        self.empty_vao = ctx.vertex_array(self.fog, [])
        self.empty_vao_direct = ctx.vertex_array(self.direct, [])

    def render_gbuffer(self, geometry: SceneGeometry, view: CameraView) -> tuple[moderngl.Texture, moderngl.Texture]:
        """(geometry, normal) RGBA32F textures: (distance to eye, KIND_*, material, 0) and world normals
        (cleared to 0: KIND_NONE where no surface is seen)."""
        ctx = self.ctx
        size = (view.width, view.height)
        geo, nrm = ctx.texture(size, 4, dtype="f4"), ctx.texture(size, 4, dtype="f4")
        for t in (geo, nrm):
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        depth = ctx.depth_renderbuffer(size)
        fbo = ctx.framebuffer(color_attachments=[geo, nrm], depth_attachment=depth)
        prog = self.gbuffer
        view.set_uniforms(prog)
        with bound(ctx, fbo):
            ctx.enable(moderngl.DEPTH_TEST)
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            vao = geometry.vertex_array(ctx, prog, "specular")
            if vao is not None:
                geometry.use(prog, "specular")
                _set(prog, kind=float(KIND_SPECULAR), material=0.0)
                vao.render(moderngl.TRIANGLES)
                vao.release()
            vao = geometry.vertex_array(ctx, prog, "diffuse")
            if vao is not None:
                geometry.use(prog, "diffuse")
                for i, (first, count) in enumerate(geometry.diffuse_ranges):
                    _set(prog, kind=float(KIND_DIFFUSE), material=float(i))
                    vao.render(moderngl.TRIANGLES, vertices=count, first=first)
                vao.release()
            ctx.disable(moderngl.DEPTH_TEST)
        fbo.release()
        depth.release()
        return geo, nrm

    def _common(self, prog, scene, view, frustum, shadow_map, light_res, gbuffer_geometry):
        view.set_uniforms(prog)
        for name, value in spot_constants(scene.light).items():
            _set(prog, **{name: value})
        uniform(prog, "light_view_proj").write(gl_matrix(frustum.view_proj))
        _set(prog, light_res=light_res, sigma_t=tuple(scene.medium.sigma_t))
        shadow_map.use(location=0)
        gbuffer_geometry.use(location=1)
        _set(prog, shadow_map=0, gbuffer_geometry=1)

    def _draw(self, vao, view) -> moderngl.Texture:
        ctx = self.ctx
        out = ctx.texture((view.width, view.height), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[out])
        with bound(ctx, fbo):
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            vao.render(moderngl.TRIANGLES, vertices=3)
        fbo.release()
        return out

    def render_fog(self, scene: Scene, view: CameraView, frustum: LightFrustum, box: tuple[np.ndarray, np.ndarray],
                   shadow_map: moderngl.Texture, light_res: int,
                   gbuffer_geometry: moderngl.Texture) -> moderngl.Texture:
        """Fog of ``scene`` inside ``box``, the (min, max) corners of its medium (scenes.bounds)."""
        prog = self.fog
        self._common(prog, scene, view, frustum, shadow_map, light_res, gbuffer_geometry)
        _set(prog, sigma_s=tuple(scene.medium.sigma_s), scene_min=tuple(box[0]),
             scene_max=tuple(box[1]))
        return self._draw(self.empty_vao, view)

    def render_direct(self, scene: Scene, view: CameraView, frustum: LightFrustum, shadow_map: moderngl.Texture,
                      light_res: int, gbuffer_geometry: moderngl.Texture,
                      gbuffer_normal: moderngl.Texture) -> moderngl.Texture:
        prog = self.direct
        self._common(prog, scene, view, frustum, shadow_map, light_res, gbuffer_geometry)
        gbuffer_normal.use(location=2)
        albedo = [tuple(o.albedo) for o in scene.diffuse][:MAX_DIFFUSE]
        albedo += [(0.0, 0.0, 0.0)] * (MAX_DIFFUSE - len(albedo))
        _set(prog, gbuffer_normal=2, albedo=albedo, texel_angle=2.0 * frustum.tan_half / light_res)
        return self._draw(self.empty_vao_direct, view)

    def release(self) -> None:
        for r in (self.empty_vao, self.empty_vao_direct, self.gbuffer, self.fog, self.direct):
            r.release()
