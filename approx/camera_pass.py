"""Camera passes: the G-buffer of primary hits, fog and direct lighting, and the
composition of the frame's layers on the GPU."""

from __future__ import annotations

from typing import TYPE_CHECKING

import moderngl
import numpy as np

from volcaustics.scenes.formats import KIND_DIFFUSE, KIND_SPECULAR

from .context import bound
from .glsl import program, uniform
from .glsl import set_uniforms as _set
from .light import spot_constants
from .medium_volumes import medium_defines
from .resources import FrameResources
from .transforms import gl_matrix, look_at, perspective

if TYPE_CHECKING:
    from volcaustics.scenes.model import Medium, Scene

    from .geometry import SceneGeometry
    from .light import LightFrustum
    from .medium_volumes import MediumVolumes

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

    def set_uniforms(self, prog: moderngl.Program | moderngl.ComputeShader) -> None:
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
        density = medium_defines(medium)  # a density grid: ρ and the transmittance volumes
        return {"gbuffer": (("camera/gbuffer.vert.glsl", "camera/gbuffer.frag.glsl"), {}),
                "fog": (("shade/fullscreen.vert.glsl", "shade/fog.frag.glsl"), {**fog_defines, **phase, **density}),
                "direct": (("shade/fullscreen.vert.glsl", "shade/direct.frag.glsl"),
                           {"MAX_DIFFUSE": MAX_DIFFUSE, **density}),
                "add": (("shade/fullscreen.vert.glsl", "shade/add.frag.glsl"), {})}

    def __init__(self, ctx: moderngl.Context, scene, fog_defines: dict, pool: FrameResources | None = None):
        self.ctx = ctx
        programs = {name: program(ctx, stages[0], stages[1], defines)
                    for name, (stages, defines) in self.programs(scene.medium, fog_defines).items()}
        self.gbuffer, self.fog, self.direct = programs["gbuffer"], programs["fog"], programs["direct"]
        self.add = programs["add"]
        self.empty_vao = ctx.vertex_array(self.fog, [])
        self.empty_vao_direct = ctx.vertex_array(self.direct, [])
        self.empty_vao_add = ctx.vertex_array(self.add, [])
        # where its images, framebuffers and vertex arrays live across frames: the renderer's
        # (one pool, so that what they name is held or tracked there) or its own
        self.pool = pool or FrameResources(ctx)
        self._own_pool = pool is None
        self.pool.track(self.gbuffer)

    def render_gbuffer(self, geometry: SceneGeometry, view: CameraView) -> tuple[moderngl.Texture, moderngl.Texture]:
        """(geometry, normal) RGBA32F textures: (distance to eye, KIND_*, material, 0) and world normals
        (cleared to 0: KIND_NONE where no surface is seen); the pool's, kept across frames."""
        ctx, pool = self.ctx, self.pool
        size = (view.width, view.height)
        geo, nrm = pool.texture("gbuffer_geometry", size), pool.texture("gbuffer_normal", size)
        fbo = pool.framebuffer("gbuffer_framebuffer", [geo, nrm], pool.depth("gbuffer_depth", size))
        prog = self.gbuffer
        view.set_uniforms(prog)
        with bound(ctx, fbo):
            ctx.enable(moderngl.DEPTH_TEST)
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            content = geometry.vertex_content(prog, "specular")
            if content is not None:
                geometry.use(prog, "specular")
                _set(prog, kind=float(KIND_SPECULAR), material=0.0)
                pool.vertex_array("gbuffer_specular_vertex_array", prog, content).render(moderngl.TRIANGLES)
            content = geometry.vertex_content(prog, "diffuse")
            if content is not None:
                geometry.use(prog, "diffuse")
                vao = pool.vertex_array("gbuffer_diffuse_vertex_array", prog, content)
                for i, (first, count) in enumerate(geometry.diffuse_ranges):
                    _set(prog, kind=float(KIND_DIFFUSE), material=float(i))
                    vao.render(moderngl.TRIANGLES, vertices=count, first=first)
            ctx.disable(moderngl.DEPTH_TEST)
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

    def _draw(self, vao, view, name: str) -> moderngl.Texture:
        """Draw the fullscreen ``vao`` into the pool's image ``name`` (kept across frames)."""
        out = self.pool.texture(name, (view.width, view.height))
        fbo = self.pool.framebuffer(f"{name}_framebuffer", [out])
        with bound(self.ctx, fbo):
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            vao.render(moderngl.TRIANGLES, vertices=3)
        return out

    def compose(self, images: list[moderngl.Texture], view: CameraView, name: str) -> moderngl.Texture:
        """The sum of ``images`` (RGBA32F, the view's size), added in their order into the
        pool's image ``name``: float32 adds, texel for texel, as numpy sums them on the
        host (left to right), so both give the same bits."""
        ctx = self.ctx
        out = self.pool.texture(name, (view.width, view.height))
        fbo = self.pool.framebuffer(f"{name}_framebuffer", [out])
        _set(self.add, image=0)
        with bound(ctx, fbo):
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.ONE, moderngl.ONE
            ctx.blend_equation = moderngl.FUNC_ADD, moderngl.FUNC_ADD  # colour and alpha
            for image in images:
                image.use(location=0)
                self.empty_vao_add.render(moderngl.TRIANGLES, vertices=3)
            ctx.disable(moderngl.BLEND)
        return out

    def render_fog(self, scene: Scene, view: CameraView, frustum: LightFrustum, box: tuple[np.ndarray, np.ndarray],
                   shadow_map: moderngl.Texture, light_res: int, gbuffer_geometry: moderngl.Texture,
                   volumes: MediumVolumes | None = None) -> moderngl.Texture:
        """Fog of ``scene`` inside ``box``, the (min, max) corners of its medium (scenes.bounds);
        ``volumes``: a heterogeneous medium's (``approx.medium_volumes``)."""
        prog = self.fog
        self._common(prog, scene, view, frustum, shadow_map, light_res, gbuffer_geometry)
        if volumes is not None:
            volumes.bind(prog)
        _set(prog, sigma_s=tuple(scene.medium.sigma_s), scene_min=tuple(box[0]),
             scene_max=tuple(box[1]))
        return self._draw(self.empty_vao, view, "fog")

    def render_direct(self, scene: Scene, view: CameraView, frustum: LightFrustum, shadow_map: moderngl.Texture,
                      light_res: int, gbuffer_geometry: moderngl.Texture, gbuffer_normal: moderngl.Texture,
                      volumes: MediumVolumes | None = None) -> moderngl.Texture:
        prog = self.direct
        self._common(prog, scene, view, frustum, shadow_map, light_res, gbuffer_geometry)
        if volumes is not None:
            volumes.bind(prog)
        gbuffer_normal.use(location=2)
        albedo = [tuple(o.albedo) for o in scene.diffuse][:MAX_DIFFUSE]
        albedo += [(0.0, 0.0, 0.0)] * (MAX_DIFFUSE - len(albedo))
        _set(prog, gbuffer_normal=2, albedo=albedo, texel_angle=2.0 * frustum.tan_half / light_res)
        return self._draw(self.empty_vao_direct, view, "direct")

    def release(self) -> None:
        if self._own_pool:
            self.pool.release()
        for r in (self.empty_vao, self.empty_vao_direct, self.empty_vao_add, self.gbuffer, self.fog, self.direct,
                  self.add):
            r.release()
