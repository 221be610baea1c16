"""``approx.render(scene, params) -> Frame`` and ``Renderer.draw``: the paper's whole
pipeline, one frame, to measure or to draw.

A :class:`Renderer` keeps the GL context, compiled programs and the scene's
vertex buffers (object space); changing the light, the camera, the medium, the
parameters or where the objects are (rigid transforms) retraces without
re-uploading geometry (the paper retraces every frame). Everything that depends on
them — the objects' matrices, the medium's box, which holds every mesh, the light
and the camera (``scenes.bounds``), the light frustum, the camera's far plane — is
computed per frame from the scene being rendered.

One frame pipeline, two ways to run it (docs/approx.md "A frame to draw and a frame to
measure"). :meth:`Renderer.draw` is the display frame: every pass on the GPU with no
CPU–GPU synchronization between its first pass and its composed image (the splat counts
stay on the GPU and drive indirect draws, the step images are added on the GPU, every
buffer and image persists across frames in :class:`approx.resources.FrameResources`,
pass times are timestamps read frames later). :meth:`Renderer.render` is the measured
frame: the same passes, then one read of what it reports (records, step images, counts,
pass times) after the last pass.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, cast

import moderngl
import numpy as np

from volcaustics.scenes.bounds import medium_bounds
from volcaustics.scenes.formats import (
    BEAM_DTYPE,
    DIFFERENTIAL_DTYPE,
    PHOTON_DTYPE,
    RAW_RECORD_DTYPE,
    SPLAT_DTYPE,
)

from .camera_pass import CameraPasses
from .context import gl_info, shared_context
from .controls import check_controls, controls_for
from .debug_groups import DISPLAY_FRAME, debug_group
from .denoise import denoise_images, guides
from .emission import RULES, approx_rays, draw_slots
from .frame import Frame, FramePasses, camera_view, compose, image_size, read_rgb
from .geometry import SceneGeometry
from .late_timer import LateTimer
from .layers import BOTH, LightMapRenderer
from .light import LightFrustum
from .medium_volumes import MediumVolumes
from .params import ApproxParams, balanced_beams, defines, photon_slots
from .records import emission_records, records_from_raw
from .resources import FrameResources
from .splat import SPLAT_COMMANDS, Splatter, splat_commands
from .splat_modes import splat_mode
from .timing import DisplayTimer, PassTimer, timer_queries_work
from .trace import PhotonTracer, read_raw_records

if TYPE_CHECKING:
    from volcaustics.scenes.model import Medium, Scene

__all__ = ["Frame", "Renderer", "render"]

# a storage buffer range starts at a multiple of GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT,
# at most 256 bytes on every driver (GL 4.3 §6.1.1's maximum): each step's records start on it
RANGE_ALIGNMENT = 256
# what a display frame cannot do on the GPU alone: parameter → (the value that needs the host, why)
HOST_STAGES = {"denoise": ("oidn", "OIDN denoises on the host (approx.denoise)"),
               "temporal": ("ema", "the moving average is taken on the host (approx.temporal)"),
               "emission": ("adaptive", "adaptive emission draws its slots on the host (approx.emission)")}


def _aligned(nbytes: int) -> int:
    return -(-nbytes // RANGE_ALIGNMENT) * RANGE_ALIGNMENT


class Renderer:
    """The approximation for one scene's geometry (light, camera, medium, materials may change).

    ``controls``: #defines that are not parameters of the method (``approx.controls.CONTROLS``:
    clipping to the objects' box, the deliberate faults of negative controls); every program
    this renderer compiles gets them. ``frames_in_flight``: how many display frames the
    late timer keeps before it drops the oldest unread one's times."""

    def __init__(self, scene, ctx: moderngl.Context | None = None, *, controls: dict | None = None,
                 frames_in_flight: int = 4):
        self.ctx = ctx or shared_context()
        self.scene = scene
        self.controls = check_controls(controls)
        self.geometry = SceneGeometry.upload(self.ctx, scene)
        self.light_maps = LightMapRenderer(self.ctx, self.geometry)
        self.pool = FrameResources(self.ctx)  # every frame's buffers and images, across frames
        self.pool.track(*(b for b in (self.geometry.specular, self.geometry.diffuse) if b is not None))
        self._programs: dict[tuple, PhotonTracer | CameraPasses | Splatter | Renderer] = {}
        self._use_queries = timer_queries_work(self.ctx)
        self.volumes: MediumVolumes | None = None  # a heterogeneous medium's, made on first use
        # display frames' pass times, read frames later (where the driver's timer queries work)
        self.late_timer = LateTimer(self.ctx, frames_in_flight) if self._use_queries else None

    def _cached(self, key, factory):
        if key not in self._programs:
            self._programs[key] = factory()
        return self._programs[key]

    def variant(self, controls: dict) -> Renderer:
        """A renderer of this one's scene on its context with ``controls`` added to its own
        (the decomposition's exact-transmittance images: ``approx.controls.EXACT_TRANSMITTANCE``);
        made once per set of controls and released with this one."""
        merged = check_controls({**self.controls, **controls})
        return cast(Renderer, self._cached(("variant", *sorted(merged.items())),
                                           lambda: Renderer(self.scene, self.ctx, controls=merged)))

    def _tracer(self, p: ApproxParams, medium: Medium | None = None) -> PhotonTracer:
        """The emission and trace programs for ``p`` and ``medium`` (equal defines, one program)."""
        key = ("tracer", *sorted(PhotonTracer.defines(p, self.controls, medium).items()))
        return self._cached(key, lambda: PhotonTracer(self.ctx, p, self.controls, self.pool, medium))

    def _shading_programs(self, scene, p: ApproxParams) -> tuple:
        """(CameraPasses, Splatter) for the fog program's defines and the phase function."""
        phase_key = (scene.medium.phase.kind, scene.medium.phase.g, scene.medium.is_heterogeneous)
        fog = defines(p, "fog")
        camera = self._cached(("camera", *sorted(fog.items()), phase_key),
                              lambda: CameraPasses(self.ctx, scene, fog, pool=self.pool))
        mode = splat_mode(p)
        controls = controls_for(self.controls, "splat")
        balanced = balanced_beams(p)
        splatter = self._cached(("splat", phase_key, p.splat, balanced, *sorted(controls.items())),
                                lambda: Splatter(self.ctx, scene.medium, adaptive=mode.differential_width,
                                                 density=mode.density_pass, beams=mode.beams,
                                                 balanced=balanced, controls=controls, pool=self.pool))
        return camera, splatter

    def draw(self, scene: Scene | None = None, params: ApproxParams | None = None) -> moderngl.Texture:
        """Draw one display frame and return its composed image (the ``combined`` layer)
        as an RGBA32F texture of the frame's size (row 0 at the bottom, GL's order),
        without reading anything back: no ``finish``, no read, no query wait between the
        frame's first pass and its image. The texture is the renderer's and is drawn
        over by the next frame. ``scene`` and ``params`` as :meth:`render`; the
        parameters that need the host (:data:`HOST_STAGES`) are refused (ValueError).

        Pass times, where the driver's timer queries work, come frames later from
        ``self.late_timer`` (``approx.late_timer.LateTimer``: its ``collected``)."""
        scene = scene or self.scene
        p = (params or ApproxParams()).resolved(scene)
        for name, (value, why) in HOST_STAGES.items():
            if getattr(p, name) == value:
                raise ValueError(f"draw: {name} = {value!r} needs the host ({why}); render() measures it")
        late = self.late_timer
        with debug_group(DISPLAY_FRAME):
            if late is not None:
                late.begin_frame()
            passes = self._passes(scene, p, DisplayTimer(late), keep_records=False)
            if late is not None:
                late.end_frame()
        return passes.combined

    def render(self, scene: Scene | None = None, params: ApproxParams | None = None, *, keep_records: bool = True,
               keep_guides: bool = False) -> Frame:
        """Render one measured frame: the display frame's passes, then one read of its
        records, step images, layers, counts and pass times. ``scene`` (None: the
        construction's) may replace light, medium, camera, materials or object
        transforms of the scene given at construction (same meshes, in the same order:
        else ValueError); ``params`` None: the paper's defaults; ``keep_guides``: fill
        ``Frame.guides``."""
        ctx = self.ctx
        scene = scene or self.scene
        p = (params or ApproxParams()).resolved(scene)
        timer = PassTimer(ctx, self._use_queries, self.pool)
        wall0 = time.perf_counter()
        passes = self._passes(scene, p, timer, keep_records=keep_records)
        # the frame is drawn: everything it reports is read from here on
        caustic_steps = [read_rgb(image) for image in passes.steps]
        geometry = read_rgb(passes.gbuffer_geometry)
        images = compose(caustic_steps, read_rgb(passes.fog), read_rgb(passes.direct), geometry, p)
        # the G-buffer's normal leaves the GPU only for a denoiser or a temporal filter that reads it
        normal = read_rgb(passes.gbuffer_normal) if keep_guides or p.denoise == "oidn" else None
        records = self._read_records(passes, p) if keep_records else []
        emitted = len(records[0]) if keep_records and records else None  # photons alive after emission
        timer.collect()
        loop_work = dict(zip(("lookups", "lockstep_lookups", "medium_reads"), passes.tracer.loop_work(p.steps)))
        timings = dict(timer.seconds)
        timings["trace"] = sum(v for k, v in timings.items() if k.startswith("trace_step"))
        timings["frame_wall"] = time.perf_counter() - wall0
        if p.denoise == "oidn":  # after the frame's wall time: reported beside it (approx.denoise)
            images, timings["denoise"], _ = denoise_images(
                images, *guides(scene, geometry, cast(np.ndarray, normal)))  # read for the denoiser
        return Frame(images=images, caustic_steps=caustic_steps, records=records, timings=timings,
                     timing_method=timer.method, params=p.to_dict(), photons_emitted=emitted, gl=gl_info(ctx),
                     work={"fragments": dict(timer.fragments), "primitives": dict(timer.primitives),
                           "shaded": dict(timer.shaded), **loop_work,
                           "heterogeneous": scene.medium.is_heterogeneous},
                     guides={"distance": geometry[..., 0], "normal": normal} if keep_guides else {})

    def _passes(self, scene: Scene, p: ApproxParams, timer: PassTimer | DisplayTimer, *,
                keep_records: bool) -> FramePasses:
        """Every pass of one frame, in order, into the pool's buffers and images; nothing
        read. ``keep_records``: each step's records (and kernel differentials) kept in
        its own range for the read after the frame, else one range reused by every step;
        the light maps count their fragments where ``timer`` counts work (queries read after the frame).
        Returns the frame's GPU objects."""
        pool, counted = self.pool, timer.counts
        self.geometry.place(scene)  # this frame's object transforms (meshes stay uploaded)
        box = medium_bounds(scene)  # holds light and camera: this frame's, not the construction's
        frustum = LightFrustum.for_scene(scene, *box)
        tracer = self._tracer(p, scene.medium)
        tracer.check_limits(p, keep_records=keep_records)
        camera_passes, splatter = self._shading_programs(scene, p)
        view = camera_view(scene, p, box)
        volumes = self._medium_volumes(scene, frustum, view, box, p, timer)
        if volumes is not None:
            tracer.use_medium(volumes, p.march_steps)
            splatter.volumes, splatter.march_steps = volumes, p.march_steps
        with timer.measure("layers", counted=False):  # the light maps' own queries count it
            layer_maps = self.light_maps.render_layers(frustum, p.light_res, p.layers, p.layer_strategy,
                                                       primitive_ids=tracer.id_rule, pool=pool, count=counted)
            maps = tracer.pack_maps(layer_maps, p.light_res)
            shadow_map = self.light_maps.render_map(
                frustum, p.light_res, facing=BOTH, include_diffuse=True, count=counted, pool=pool, name="shadow_map",
                target=pool.texture("shadow_map", (p.light_res, p.light_res)))
        timer.count("layers", self.light_maps.take_queries())
        with timer.measure("emission", counted=False):  # the light map's own queries count it
            emission_map = self.light_maps.render_light_map(frustum, p.photon_res, facing=BOTH, pool=pool,
                                                            name="emission_map", primitive_ids=tracer.id_rule,
                                                            count=counted)
            photons = tracer.emit_photons(scene, frustum, emission_map, p.photon_res, p.seed)
        timer.count("emission", self.light_maps.take_queries())
        with timer.measure("camera"):
            gbuf_geo, gbuf_nrm = camera_passes.render_gbuffer(self.geometry, view)
        steps = self._trace_and_splat(timer, tracer, splatter, scene, frustum, box, maps, photons, view, gbuf_geo, p,
                                      keep_records)
        with timer.measure("fog"):
            fog = camera_passes.render_fog(scene, view, frustum, box, shadow_map, p.light_res, gbuf_geo, volumes)
        with timer.measure("direct"):
            direct = camera_passes.render_direct(scene, view, frustum, shadow_map, p.light_res, gbuf_geo, gbuf_nrm,
                                                 volumes)
        with timer.measure("compose", counted=False):  # the caustic as the host sums it, then the frame
            caustic = camera_passes.compose(steps["images"], view, "caustic")
            combined = camera_passes.compose([caustic, fog, direct], view, "combined")
        return FramePasses(tracer, steps["images"], steps["records"], steps["kernels"], steps["stride"], gbuf_geo,
                           gbuf_nrm, fog, direct, caustic, combined)

    def _medium_volumes(self, scene: Scene, frustum: LightFrustum, view, box, p: ApproxParams,
                        timer: PassTimer | DisplayTimer | None = None) -> MediumVolumes | None:
        """A heterogeneous medium's grid and this frame's transmittance volumes (a pass of
        their own, ``volumes``); None for a homogeneous medium."""
        if not scene.medium.is_heterogeneous:
            return None
        if self.volumes is None:
            self.volumes = MediumVolumes(self.ctx, self.pool)
        if timer is None:
            self.volumes.update(scene, frustum, view.eye, view.view_proj, box, p)
        else:
            with timer.measure("volumes"):
                self.volumes.update(scene, frustum, view.eye, view.view_proj, box, p)
        return self.volumes

    def _use_medium(self, splatter: Splatter, scene: Scene, view, box, p: ApproxParams) -> None:
        """Give ``splatter`` a heterogeneous medium's grid and volumes for splats from any source."""
        volumes = self._medium_volumes(scene, LightFrustum.for_scene(scene, *box), view, box, p)
        if volumes is not None:
            splatter.volumes, splatter.march_steps = volumes, p.march_steps

    def _trace_and_splat(self, timer, tracer, splatter, scene, frustum, box, maps, photons, view, gbuf_geo,
                         p: ApproxParams, keep_records: bool) -> dict:
        """Every interaction step: trace (paper §4.1), then splat its medium collisions
        (§4.3) into one image per step (the pool's ``caustic_step{k}``), the splat count
        on the GPU from the compaction to the indirect draw. Returns the step images,
        the records buffer, the kernel differentials' buffer (or None) and the records'
        stride per step (0: one range for every step)."""
        pool, count = self.pool, photon_slots(p)
        step_bytes = _aligned(count * RAW_RECORD_DTYPE.itemsize)
        stride = step_bytes if keep_records else 0
        record_buf = pool.buffer("records", step_bytes * (p.steps if keep_records else 1))
        splat_buf = pool.buffer("splats", count * SPLAT_DTYPE.itemsize)
        commands = pool.buffer("splat_commands", SPLAT_COMMANDS["nbytes"])
        kernel_source = tracer.kernel_source()
        kernels = (pool.buffer("kernel_differentials", p.steps * count * DIFFERENTIAL_DTYPE.itemsize)
                   if keep_records and kernel_source is not None else None)
        tracer.start_frame(p.steps)
        images = []
        for step in range(1, p.steps + 1):
            offset = (step - 1) * stride
            with timer.measure(f"trace_step{step}"):
                tracer.trace_step(scene, frustum, box, maps, p.light_res, photons, record_buf, count, step, p.seed,
                                  objects_box=self.geometry.objects_box, records_offset=offset)
            with timer.measure("splat"):
                tracer.compact_splats(record_buf, count, splat_buf, commands, p, step, records_offset=offset)
                if tracer.balanced:  # a pilot of the beams at their differential widths, then widths it balances
                    balance = splatter.balance_map(splat_buf, commands, view, scene.medium, p.splat_radius, gbuf_geo)
                    tracer.compact_splats(record_buf, count, splat_buf, commands, p, step, records_offset=offset,
                                          balance=(balance, view))
            if kernels is not None:  # this step's kernels (as the compaction left them), for the read after the frame
                self.ctx.memory_barrier()
                size = count * DIFFERENTIAL_DTYPE.itemsize
                self.ctx.copy_buffer(kernels, cast(moderngl.Buffer, kernel_source), size,
                                     write_offset=(step - 1) * size)
            grid = None
            if splatter.density_program is not None:  # the density pre-pass, a pass of its own
                with timer.measure("density"):
                    grid = splatter.density_grid(splat_buf, commands, view)
            with timer.measure("splat"):
                image = pool.texture(f"caustic_step{step}", image_size(p))
                if "STEP_IMAGES_KEPT" not in self.controls:  # the control: last frame's splats stay
                    pool.framebuffer(f"caustic_step{step}_framebuffer", [image]).clear(0.0, 0.0, 0.0, 0.0)
                splatter.splat(splat_buf, commands, view, scene.medium, p.splat_radius, gbuf_geo, image,
                               p.splat_neighbours, grid=grid, name=f"caustic_step{step}")
            images.append(image)
        return {"images": images, "records": record_buf, "kernels": kernels, "stride": stride}

    def _read_records(self, passes: FramePasses, p: ApproxParams) -> list:
        """Per step its records (RECORD_DTYPE, active photons) from a measured frame's buffers."""
        count, stride = photon_slots(p), passes.record_stride
        records = []
        for step in range(1, p.steps + 1):
            raw = read_raw_records(passes.records, count, (step - 1) * stride)
            kernels = None
            if passes.kernels is not None:
                size = count * DIFFERENTIAL_DTYPE.itemsize
                kernels = np.frombuffer(passes.kernels.read(size=size, offset=(step - 1) * size),
                                        DIFFERENTIAL_DTYPE).copy()
            records.append(records_from_raw(raw, step, differentials=kernels))
        return records

    def depth_levels(self, scene: Scene | None = None, light_res: int = 256) -> list[int]:
        """Per peeled level of the light maps (``approx.layers``: the i-th front and back
        face along each light ray), the texels of a light_res² map it covers on ``scene``
        (None: the construction's): the scene's depth complexity from the light, which
        ``layers_needed`` turns into layers = auto. Reads queries: not a display frame's."""
        scene = scene or self.scene
        self.geometry.place(scene)
        frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
        return self.light_maps.depth_levels(frustum, light_res)

    def first_records(self, scene: Scene | None, params: ApproxParams, seeds: Iterable[int]) -> list:
        """Per seed in ``seeds``, the emission state an exact replay starts from: the
        fields photon, start, direction, inside and power_start of the step-1 records
        (RECORD_DTYPE, the other fields 0) of a frame with ``params`` and that seed,
        read from the photon buffer after emission (what step 1 of the tracer copies
        into its records), with the emission map rendered once for all seeds."""
        scene = scene or self.scene
        p = params.resolved(scene)
        self.geometry.place(scene)
        box = medium_bounds(scene)
        frustum = LightFrustum.for_scene(scene, *box)
        tracer = self._tracer(p, scene.medium)
        tracer.check_limits(p, keep_records=True)
        volumes = self._medium_volumes(scene, frustum, camera_view(scene, p, box), box, p)
        if volumes is not None:  # emission carries the light's path through the grid
            tracer.use_medium(volumes, p.march_steps)
        emission_map = self.light_maps.render_light_map(frustum, p.photon_res, facing=BOTH, pool=self.pool,
                                                        name="emission_map", primitive_ids=tracer.id_rule, count=False)
        out = []
        for seed in seeds:
            photons = tracer.emit_photons(scene, frustum, emission_map, p.photon_res, seed)
            self.ctx.memory_barrier()
            out.append(emission_records(np.frombuffer(photons.read(), PHOTON_DTYPE)))
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
        tracer = self._tracer(p, scene.medium)
        importance = None
        if tracer.emission_adaptive:
            self.geometry.place(scene)
            emission_map = self.light_maps.render_light_map(frustum, p.photon_res, facing=BOTH, pool=self.pool,
                                                            name="emission_map", primitive_ids=tracer.id_rule,
                                                            count=False)
            emission_map.surface.use(location=0)
            importance = tracer.importance_map(scene, frustum, p.photon_res)
        if importance is None and p.emission_jitter == "center":  # texel centres whatever the seed: one set for all
            return [approx_rays(scene.light, frustum, p.photon_res, 0, shift=tracer.emission_shift)] * len(seeds)
        return [approx_rays(scene.light, frustum, p.photon_res, seed, jitter=p.emission_jitter,
                            slots=None if importance is None else draw_slots(importance, seed))
                for seed in seeds]

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
        scene = scene or self.scene
        p = (params or ApproxParams()).resolved(scene)
        dtype, name = (BEAM_DTYPE, "BEAM_DTYPE") if splat_mode(p).beams else (SPLAT_DTYPE, "SPLAT_DTYPE")
        for splats in sets:
            if splats.dtype != dtype or splats.ndim != 1:
                raise ValueError(f"splats: expected a 1-D array of {name} rows (splat = {p.splat}), "
                                 f"got {splats.dtype} {splats.shape}")
        self.geometry.place(scene)
        box = medium_bounds(scene)
        view = camera_view(scene, p, box)
        camera_passes, splatter = self._shading_programs(scene, p)
        self._use_medium(splatter, scene, view, box, p)
        gbuf_geo, _ = camera_passes.render_gbuffer(self.geometry, view)
        commands = self.pool.buffer("splat_commands", SPLAT_COMMANDS["nbytes"])
        image = self.pool.texture("splat_image", image_size(p))
        images = []
        for splats in sets:
            self.pool.framebuffer("splat_image_framebuffer", [image]).clear(0.0, 0.0, 0.0, 0.0)
            if len(splats):
                buf = self.pool.buffer("splat_rows", splats.nbytes)
                buf.write(splats.tobytes())
                commands.write(splat_commands(len(splats)))
                splatter.splat(buf, commands, view, scene.medium, p.splat_radius, gbuf_geo, image,
                               p.splat_neighbours, name="splat_image")
            images.append(read_rgb(image))
        return images

    def density_widths(self, splats: np.ndarray, field: np.ndarray, scene: Scene | None = None,
                       params: ApproxParams | None = None) -> np.ndarray:
        """splat = density: the kernel σ (m, float32 per row of ``splats``; 0 for a row that
        is not a collision) :meth:`splat` gives ``splats`` (SPLAT_DTYPE) when its density
        pre-pass counts the splats ``field`` instead (``approx.splat.Splatter.density_widths``):
        other photons splatted with the widths of a frame whose collisions were ``field``."""
        scene = scene or self.scene
        p = (params or ApproxParams()).resolved(scene)
        if not splat_mode(p).density_pass:
            raise ValueError(f"density_widths: splat = {p.splat!r}, expected 'density'")
        if not len(splats):
            return np.zeros(0, np.float32)
        _, splatter = self._shading_programs(scene, p)
        box = medium_bounds(scene)
        view = camera_view(scene, p, box)
        self._use_medium(splatter, scene, view, box, p)
        buffers = [self.ctx.buffer(np.ascontiguousarray(a, SPLAT_DTYPE).tobytes() or bytes(SPLAT_DTYPE.itemsize))
                   for a in (splats, field)]
        try:
            return splatter.density_widths(buffers[0], len(splats), buffers[1], len(field), view, p.splat_radius,
                                           p.splat_neighbours)
        finally:
            for b in buffers:
                b.release()

    def release(self) -> None:
        if self.late_timer is not None:
            self.late_timer.release()
        for prog in self._programs.values():
            prog.release()
        self.pool.release()
        self.light_maps.release()
        self.geometry.release()


def render(scene: Scene, params: ApproxParams | None = None, **kwargs: bool) -> Frame:
    """Render one frame of ``scene`` with the paper's method (see :class:`Renderer`)."""
    renderer = Renderer(scene)
    try:
        return renderer.render(scene, params, **kwargs)
    finally:
        renderer.release()
