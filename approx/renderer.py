"""``approx.render(scene, params) -> Frame``: the paper's whole pipeline, one frame.

A :class:`Renderer` keeps the GL context, compiled programs and the scene's
vertex buffers (object space); changing the light, the camera, the medium, the
parameters or where the objects are (rigid transforms) retraces without
re-uploading geometry (the paper retraces every frame). Everything that depends on
them — the objects' matrices, the medium's box, which holds every mesh, the light
and the camera (``scenes.bounds``), the light frustum, the camera's far plane — is
computed per frame from the scene being rendered.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

import moderngl
import numpy as np

from volcaustics.scenes.bounds import medium_bounds
from volcaustics.scenes.formats import BEAM_DTYPE, KIND_SPECULAR, PHOTON_DTYPE, RAW_RECORD_DTYPE, SPLAT_DTYPE

from .camera_pass import CameraPasses, CameraView
from .context import gl_info, shared_context
from .controls import check_controls, controls_for
from .denoise import denoise_images, guides
from .emission import RULES, approx_rays, draw_slots
from .geometry import SceneGeometry
from .layers import BOTH, LightMapRenderer
from .light import LightFrustum
from .params import ApproxParams, defines, photon_slots
from .records import emission_records, records_from_raw
from .splat import Splatter
from .timing import PassTimer, timer_queries_work
from .trace import PhotonTracer, read_raw_records

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene


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
        step: the photons' own, and their subgroups' in lockstep, ``Tracer.loop_work``).
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


def _read_rgb(tex: moderngl.Texture) -> np.ndarray:
    w, h = tex.size
    rgba = np.frombuffer(tex.read(), dtype=np.float32).reshape(h, w, 4)
    return np.ascontiguousarray(rgba[::-1, :, :3])


class Renderer:
    """The approximation for one scene's geometry (light, camera, medium, materials may change).

    ``controls``: #defines that are not parameters of the method (``approx.controls.CONTROLS``:
    clipping to the objects' box, the deliberate faults of negative controls); every program
    this renderer compiles gets them."""

    def __init__(self, scene, ctx: moderngl.Context | None = None, *, controls: dict | None = None):
        self.ctx = ctx or shared_context()
        self.scene = scene
        self.controls = check_controls(controls)
        self.geometry = SceneGeometry.upload(self.ctx, scene)
        self.light_maps = LightMapRenderer(self.ctx, self.geometry)
        self._programs: dict[tuple, PhotonTracer | CameraPasses | Splatter] = {}
        self._use_queries = timer_queries_work(self.ctx)

    def _cached(self, key, factory):
        if key not in self._programs:
            self._programs[key] = factory()
        return self._programs[key]

    def _tracer(self, p: ApproxParams) -> PhotonTracer:
        """The emission and trace programs for ``p`` (equal defines, one program)."""
        key = ("tracer", *sorted(PhotonTracer.defines(p, self.controls).items()))
        return self._cached(key, lambda: PhotonTracer(self.ctx, p, self.controls))

    def _shading_programs(self, scene, p: ApproxParams) -> tuple:
        """(CameraPasses, Splatter) for the fog program's defines and the phase function."""
        phase_key = (scene.medium.phase.kind, scene.medium.phase.g)
        fog = defines(p, "fog")
        camera = self._cached(("camera", *sorted(fog.items()), phase_key), lambda: CameraPasses(self.ctx, scene, fog))
        controls = controls_for(self.controls, "splat") if p.splat in ("density", "beams") else {}
        splatter = self._cached(("splat", phase_key, p.splat, *sorted(controls.items())),
                                lambda: Splatter(self.ctx, scene.medium, adaptive=p.splat == "adaptive",
                                                 density=p.splat == "density", beams=p.splat == "beams",
                                                 controls=controls))
        return camera, splatter

    def _black_image(self, p: ApproxParams) -> moderngl.Texture:
        """An RGBA32F image of the frame's size cleared to 0 (splats add into it)."""
        image = self.ctx.texture(image_size(p), 4, dtype="f4")
        fbo = self.ctx.framebuffer(color_attachments=[image])
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        fbo.release()
        return image

    def render(self, scene: Scene | None = None, params: ApproxParams | None = None, *, keep_records: bool = True,
               keep_guides: bool = False) -> Frame:
        """Render one frame. ``scene`` (None: the construction's) may replace light,
        medium, camera, materials or object transforms of the scene given at
        construction (same meshes, in the same order: else ValueError);
        ``params`` None: the paper's defaults; ``keep_guides``: fill ``Frame.guides``."""
        ctx = self.ctx
        scene = scene or self.scene
        p = (params or ApproxParams()).resolved(scene)
        self.geometry.place(scene)  # this frame's object transforms (meshes stay uploaded)
        timer = PassTimer(ctx, self._use_queries)
        wall0 = time.perf_counter()
        box = medium_bounds(scene)  # holds light and camera: this frame's, not the construction's
        frustum = LightFrustum.for_scene(scene, *box)
        tracer = self._tracer(p)
        tracer.check_limits(p, keep_records=keep_records)
        camera_passes, splatter = self._shading_programs(scene, p)
        released: list = []
        maps = self._light_maps(timer, tracer, frustum, p, released)
        with timer.measure("emission", counted=False):  # the light map's own queries count it
            self.light_maps.take_drawn()
            emission_map = self.light_maps.render_light_map(frustum, p.photon_res, facing=BOTH,
                                                            primitive_ids=tracer.id_rule)
            photons = tracer.emit_photons(scene, frustum, emission_map, p.photon_res, p.seed)
        timer.add("emission", *self.light_maps.take_drawn())
        released += [emission_map, photons]
        view = _camera_view(scene, p, box)
        with timer.measure("camera"):
            gbuf_geo, gbuf_nrm = camera_passes.render_gbuffer(self.geometry, view)
        released += [gbuf_geo, gbuf_nrm]
        records, caustic_steps, loop_work = self._trace_and_splat(timer, tracer, splatter, scene, frustum, box, maps,
                                                                photons, view, gbuf_geo, p, keep_records, released)
        with timer.measure("fog"):
            fog_tex = camera_passes.render_fog(scene, view, frustum, box, maps["shadow"], p.light_res, gbuf_geo)
        with timer.measure("direct"):
            direct_tex = camera_passes.render_direct(scene, view, frustum, maps["shadow"], p.light_res, gbuf_geo,
                                                     gbuf_nrm)
        released += [fog_tex, direct_tex]
        geometry = _read_rgb(gbuf_geo)
        images = _compose(caustic_steps, _read_rgb(fog_tex), _read_rgb(direct_tex), geometry, p)
        # the G-buffer's normal leaves the GPU only for a denoiser or a temporal filter that reads it
        normal = _read_rgb(gbuf_nrm) if keep_guides or p.denoise == "oidn" else None
        emitted = len(records[0]) if keep_records and records else None  # photons alive after emission
        for r in released:
            r.release()
        timings = dict(timer.seconds)
        timings["trace"] = sum(v for k, v in timings.items() if k.startswith("trace_step"))
        timings["frame_wall"] = time.perf_counter() - wall0
        if p.denoise == "oidn":  # after the frame's wall time: reported beside it (approx.denoise)
            images, timings["denoise"], _ = denoise_images(
                images, *guides(scene, geometry, cast(np.ndarray, normal)))  # read for the denoiser
        return Frame(images=images, caustic_steps=caustic_steps, records=records, timings=timings,
                     timing_method=timer.method, params=p.to_dict(), photons_emitted=emitted, gl=gl_info(ctx),
                     work={"fragments": dict(timer.fragments), "primitives": dict(timer.primitives),
                           "shaded": dict(timer.shaded), **loop_work},
                     guides={"distance": geometry[..., 0], "normal": normal} if keep_guides else {})

    def first_records(self, scene: Scene | None, params: ApproxParams, seeds: Iterable[int]) -> list:
        """Per seed in ``seeds``, the emission state an exact replay starts from: the
        fields photon, start, direction, inside and power_start of the step-1 records
        (RECORD_DTYPE, the other fields 0) of a frame with ``params`` and that seed,
        read from the photon buffer after emission (what step 1 of the tracer copies
        into its records), with the emission map rendered once for all seeds."""
        scene = scene or self.scene
        p = params.resolved(scene)
        self.geometry.place(scene)
        frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
        tracer = self._tracer(p)
        tracer.check_limits(p, keep_records=True)
        emission_map = self.light_maps.render_light_map(frustum, p.photon_res, facing=BOTH,
                                                        primitive_ids=tracer.id_rule)
        out = []
        try:
            for seed in seeds:
                photons = tracer.emit_photons(scene, frustum, emission_map, p.photon_res, seed)
                try:
                    out.append(emission_records(np.frombuffer(photons.read(), PHOTON_DTYPE)))
                finally:
                    photons.release()
        finally:
            emission_map.release()
        return out

    def emission_rays(self, scene: Scene | None, params: ApproxParams, seeds: Sequence[int]) -> list:
        """Per seed in ``seeds``, the rays the approximation emits along
        (``approx.emission.approx_rays``: emission_jitter's points in every texel, or
        adaptive emission's slots, drawn from the importance of the emission map rendered
        once): what an exact
        replay from the emission ray starts from."""
        scene = scene or self.scene
        p = params.resolved(scene)
        if p.emission not in RULES:  # a rule the shader knows and its numpy twin does not: E would replay another
            raise NotImplementedError(f"emission = {p.emission!r}: approx.emission.approx_rays has no rays for it")
        frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
        tracer = self._tracer(p)
        importance = None
        if tracer.emission_adaptive:
            self.geometry.place(scene)
            emission_map = self.light_maps.render_light_map(frustum, p.photon_res, facing=BOTH,
                                                            primitive_ids=tracer.id_rule)
            try:
                emission_map.surface.use(location=0)
                importance = tracer.importance_map(scene, frustum, p.photon_res)
            finally:
                emission_map.release()
        if importance is None and p.emission_jitter == "center":  # texel centres whatever the seed: one set for all
            return [approx_rays(scene.light, frustum, p.photon_res, 0, shift=tracer.emission_shift)] * len(seeds)
        return [approx_rays(scene.light, frustum, p.photon_res, seed, jitter=p.emission_jitter,
                            slots=None if importance is None else draw_slots(importance, seed))
                for seed in seeds]

    def _light_maps(self, timer, tracer, frustum, p: ApproxParams, released: list) -> dict:
        """The light layers (paper Fig. 1A, 3) packed for the tracer, and the shadow map."""
        self.light_maps.take_drawn()
        with timer.measure("layers", counted=False):  # the light maps' own queries count it
            layer_maps = self.light_maps.render_layers(frustum, p.light_res, p.layers, p.layer_strategy,
                                                       primitive_ids=tracer.id_rule)
            map_texels, map_bounds = tracer.map_buffer(layer_maps, p.light_res)
            # exact distance range of each map's surfaces (a little slack for float rounding)
            map_info = [(b is not None, b[0] * (1 - 1e-5), b[1] * (1 + 1e-5)) if b else (False, 0.0, 0.0)
                        for b in map_bounds]
            shadow_map = self.light_maps.render_map(frustum, p.light_res, facing=BOTH, include_diffuse=True)
        timer.add("layers", *self.light_maps.take_drawn())
        released += layer_maps + [shadow_map, map_texels]
        return {"texels": map_texels, "info": map_info, "shadow": shadow_map}

    def _trace_and_splat(self, timer, tracer, splatter, scene, frustum, box, maps, photons, view, gbuf_geo,
                         p: ApproxParams, keep_records: bool, released: list) -> tuple:
        """Every interaction step: trace (paper §4.1), then splat its medium collisions
        (§4.3) into one image per step; (records per step, caustic image per step, the
        trace loop's work over the steps: ``lookups`` and ``lockstep_lookups``)."""
        count = photon_slots(p)
        records, caustic_steps, loop_work = [], [], {"lookups": 0, "lockstep_lookups": 0}
        record_buf = self.ctx.buffer(reserve=count * RAW_RECORD_DTYPE.itemsize)
        splat_buf = self.ctx.buffer(reserve=count * SPLAT_DTYPE.itemsize)
        released += [record_buf, splat_buf]
        geo = self.geometry
        for step in range(1, p.steps + 1):
            with timer.measure(f"trace_step{step}"):
                tracer.trace_step(scene, frustum, box, maps["texels"], maps["info"], p.light_res, photons, record_buf,
                                  count, step, p.seed, objects_box=geo.objects_box)
            for name, n in zip(loop_work, tracer.loop_work()):
                loop_work[name] += n
            with timer.measure("splat"):
                n_splats = tracer.compact_splats(record_buf, count, splat_buf, p, step)
            grid = None
            if splatter.density_program is not None:  # the density pre-pass, a pass of its own
                with timer.measure("density"):
                    grid = splatter.density_grid(splat_buf, n_splats, view)
                released.append(grid)
            with timer.measure("splat"):
                step_image = self._black_image(p)
                splatter.splat(splat_buf, n_splats, view, scene.medium, p.splat_radius, gbuf_geo, step_image,
                               p.splat_neighbours, grid=grid)
            caustic_steps.append(_read_rgb(step_image))
            step_image.release()
            if keep_records:
                records.append(records_from_raw(read_raw_records(record_buf, count), step,
                                                differentials=tracer.kernel_differentials(count)))
        return records, caustic_steps, loop_work

    def splat(self, splats: np.ndarray, scene: Scene | None = None, params: ApproxParams | None = None) -> np.ndarray:
        """The caustic image of photons from any source, through this frame's own
        splatting (paper §3, Eq. 5, §4.3): the same view, G-buffer depth test,
        ``splat_radius``, medium weights and phase as :meth:`render`.

        Parameters
        ----------
        splats : N rows of ``scenes.formats.SPLAT_DTYPE``: medium collisions (world
            positions in metres, unit propagation directions before scattering, RGB
            power in W after transmittance), e.g. from
            :func:`approx.splat.splats_from_arrays`. Rows whose status is not
            STATUS_COLLIDED draw nothing. With ``params.splat`` = beams: BEAM_DTYPE rows
            (photon beams, e.g. from :func:`approx.splat.beams_from_arrays`).
        scene : replaces light, camera or medium of the construction's scene (same
            meshes), as in :meth:`render`.
        params : the approximation's parameters; only width, height and
            splat_radius and splat = beams or not matter (width/height unset take the
            scene camera's).

        Returns
        -------
        H×W×3 float32, linear Rec.709 radiance (W·m⁻²·sr⁻¹), row 0 at the top: the
        single-scattered radiance of the splats as the camera sees it, the
        ``caustic`` layer of :meth:`render` for the same photons.
        """
        return self.splat_many([splats], scene, params)[0]

    def splat_many(self, splat_sets: Iterable[np.ndarray], scene: Scene | None = None,
                   params: ApproxParams | None = None) -> list:
        """:meth:`splat` for several photon sets in one view: one image per set, the
        G-buffer rendered once (independent photon subsets, batches)."""
        sets = [np.ascontiguousarray(s) for s in splat_sets]
        ctx = self.ctx
        scene = scene or self.scene
        p = (params or ApproxParams()).resolved(scene)
        dtype, name = (BEAM_DTYPE, "BEAM_DTYPE") if p.splat == "beams" else (SPLAT_DTYPE, "SPLAT_DTYPE")
        for splats in sets:
            if splats.dtype != dtype or splats.ndim != 1:
                raise ValueError(f"splats: expected a 1-D array of {name} rows (splat = {p.splat}), "
                                 f"got {splats.dtype} {splats.shape}")
        self.geometry.place(scene)
        view = _camera_view(scene, p, medium_bounds(scene))
        camera_passes, splatter = self._shading_programs(scene, p)
        gbuf_geo, gbuf_nrm = camera_passes.render_gbuffer(self.geometry, view)
        images = []
        try:
            for splats in sets:
                image = self._black_image(p)
                try:
                    if len(splats):
                        buf = ctx.buffer(splats.tobytes())
                        try:
                            splatter.splat(buf, len(splats), view, scene.medium, p.splat_radius, gbuf_geo, image,
                                           p.splat_neighbours)
                        finally:
                            buf.release()
                    images.append(_read_rgb(image))
                finally:
                    image.release()
        finally:
            gbuf_geo.release()
            gbuf_nrm.release()
        return images

    def density_widths(self, splats: np.ndarray, field: np.ndarray, scene: Scene | None = None,
                       params: ApproxParams | None = None) -> np.ndarray:
        """splat = density: the kernel σ (m, float32 per row of ``splats``; 0 for a row that
        is not a collision) :meth:`splat` gives ``splats`` (SPLAT_DTYPE) when its density
        pre-pass counts the splats ``field`` instead (``approx.splat.Splatter.density_widths``):
        other photons splatted with the widths of a frame whose collisions were ``field``."""
        scene = scene or self.scene
        p = (params or ApproxParams()).resolved(scene)
        if p.splat != "density":
            raise ValueError(f"density_widths: splat = {p.splat!r}, expected 'density'")
        if not len(splats):
            return np.zeros(0, np.float32)
        _, splatter = self._shading_programs(scene, p)
        view = _camera_view(scene, p, medium_bounds(scene))
        buffers = [self.ctx.buffer(np.ascontiguousarray(a, SPLAT_DTYPE).tobytes() or bytes(SPLAT_DTYPE.itemsize))
                   for a in (splats, field)]
        try:
            return splatter.density_widths(buffers[0], len(splats), buffers[1], len(field), view, p.splat_radius,
                                           p.splat_neighbours)
        finally:
            for b in buffers:
                b.release()

    def release(self) -> None:
        for prog in self._programs.values():
            prog.release()
        self.light_maps.release()
        self.geometry.release()


def image_size(p: ApproxParams) -> tuple[int, int]:
    """(width, height) of resolved parameters (``ApproxParams.resolved``: both set)."""
    return cast(int, p.width), cast(int, p.height)


def _compose(caustic_steps: list, fog, direct, gbuffer, p: ApproxParams) -> dict:
    """The frame's layers (``scenes.formats.LAYER_NAMES``) from the passes' images."""
    caustic = (np.sum(caustic_steps, axis=0).astype(np.float32) if caustic_steps
               else np.zeros((*image_size(p)[::-1], 3), np.float32))
    kind = gbuffer[:, :, 1]
    mask = np.repeat((np.round(kind) == KIND_SPECULAR).astype(np.float32)[:, :, None], 3, axis=2)
    return {"caustic": caustic, "fog": fog, "direct": direct, "combined": caustic + fog + direct,
            "mask_specular": mask}


def _camera_view(scene, p: ApproxParams, box) -> CameraView:
    """The camera of a frame at the resolved image size; the far plane beyond the medium's box."""
    return CameraView(scene.camera, *image_size(p), far=2.0 * float(np.linalg.norm(box[1] - box[0])))


def render(scene: Scene, params: ApproxParams | None = None, **kwargs: bool) -> Frame:
    """Render one frame of ``scene`` with the paper's method (see :class:`Renderer`)."""
    renderer = Renderer(scene)
    try:
        return renderer.render(scene, params, **kwargs)
    finally:
        renderer.release()
