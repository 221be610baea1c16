"""Emission and the image-based photon tracer (paper §4.1–4.3) on compute shaders.

Why the splatted power is right: in the medium a photon collides at rate
sigma_bar (``scenes.model.Medium.sigma_bar``, the mean of sigma_t over RGB; free
flight d = −ln(1−ξ)/sigma_bar) and keeps going after each collision, while its
power follows the deterministic transmittance exp(−sigma_t·s) of the distance s
travelled. The expected number of collisions in ds is sigma_bar·ds, each
splatting power Φ(s)·sigma_s/sigma_bar, so the expected splatted power density
is sigma_s·Φ0·exp(−sigma_t·s): exactly the single-scattering source along the
refracted beam. With grey media sigma_bar = sigma_t and the weight is the
paper's σs/σt.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, cast

import moderngl
import numpy as np

from volcaustics.scenes.formats import DIFFERENTIAL_DTYPE, PHOTON_DTYPE, RAW_RECORD_DTYPE

from .controls import controls_for
from .emission import draw_slots
from .glsl import compute_shader, set_uniforms, uniform
from .light import spot_constants
from .limits import check_fits, max_image_size
from .map_packing import MapBuffers, MapPacker, map_bounds, pyramid_layout
from .medium_volumes import medium_defines
from .params import carries_differentials
from .params import defines as table_defines
from .splat import BEAM_SIGMA_FLOOR
from .transforms import gl_matrix

if TYPE_CHECKING:
    from volcaustics.scenes.model import Medium, Scene

    from .camera_pass import CameraView
    from .layers import LightMap
    from .light import LightFrustum
    from .medium_volumes import MediumVolumes
    from .params import ApproxParams, ParamsMethods
    from .resources import FrameResources

MAX_MATERIALS = 16
COMPACT_BLOCK = 256  # BLOCK of splat/compact.comp.glsl
WORK_COUNTERS = 3  # per step: lookups, lockstep lookups, medium reads (trace.comp.glsl Work)
WORK_BYTES = 4 * WORK_COUNTERS

# Start offset of a segment leaving a surface, in light-map texel footprints
# (common/start_offset.glsl): footprint · (START_SLOPE·sin θ + START_FLOOR) / |d·n|, at most START_MAX.
# Fewest skipped hits + false re-hits in bench/start_offset.py: docs/decisions.md "Start offset".
START_OFFSET = {"START_SLOPE": 0.7, "START_FLOOR": 0.25, "START_MAX": 2.0}

def _materials(scene):
    if len(scene.specular) > MAX_MATERIALS:
        raise ValueError(f"at most {MAX_MATERIALS} specular objects are supported, scene has {len(scene.specular)}")
    unused = MAX_MATERIALS - len(scene.specular)
    ior = [o.ior for o in scene.specular] + [1.0] * unused
    absorption = [tuple(o.absorption) for o in scene.specular] + [(0.0, 0.0, 0.0)] * unused
    return ior, absorption


class PhotonTracer:
    """Holds the compute programs for one setting of the trace program's defines
    (:meth:`defines`: the parameter table's ``program="trace"`` entries)."""

    def __init__(self, ctx: moderngl.Context, params, controls: dict | None = None,
                 pool: FrameResources | None = None, medium: Medium | None = None):
        self.ctx = ctx
        # where the frame's buffers live across frames (a renderer's); without one each call
        # makes its own: the photons for the caller to release, the rest released here
        self.pool = pool
        defines = self.defines(params, controls, medium)
        shaders = {name: compute_shader(ctx, *source)
                   for name, source in self.programs(params, controls, medium).items()}
        self.heterogeneous = "HETEROGENEOUS" in defines  # a density grid: emission and trace read it
        self.volumes: MediumVolumes | None = None  # ... this frame's (use_medium)
        self.march_steps = 16
        self.emit, self.trace = shaders["emit"], shaders["trace"]
        self.id_rule = "START_RULE_ID" in defines  # start rule id: the maps carry primitive ids
        self.packer = MapPacker(ctx, shaders["pack"], shaders.get("pyramid"), self._buffer, primitive=self.id_rule)
        self.compact_count, self.compact_write = shaders["compact_count"], shaders["compact_write"]
        self.compact_scan = shaders["compact_scan"]
        self.adaptive = "SPLAT_ADAPTIVE" in defines
        self.beam_differential = "BEAM_DIFFERENTIAL" in defines
        self.balanced = "BEAM_BALANCED" in defines  # beam_width = balanced: compact_splats scales by a balance map
        self.carries_differentials = "DIFFERENTIALS" in defines
        # splat = adaptive or beam_width = differential: the photons' DIFFERENTIAL_DTYPE buffer of this frame
        self.differentials: moderngl.Buffer | None = None
        # beam_width = differential: per photon the differential at its step's segment start (DIFFERENTIAL_DTYPE)
        self.segment_differentials: moderngl.Buffer | None = None
        self.splits = int(defines.get("FRESNEL_SPLITS", 0))  # fresnel_splits (scenes.splitting)
        self.emission_adaptive = "EMISSION_ADAPTIVE" in defines
        self.emission_shift = float(defines.get("EMISSION_SHIFT", 0.0))  # texels (a test's wrong grid, emit.comp.glsl)
        self.importance = shaders.get("importance")
        self.maps = defines["MAPS"]
        # per step its lookups, own and lockstep, and its medium reads (trace.comp.glsl Work), zeroed by start_frame
        self.work: moderngl.Buffer | None = None
        self._solid_angles: dict[tuple, moderngl.Buffer] = {}
        self._max_groups = int(ctx.info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"][0])
        self._max_size = max_image_size(ctx.info)

    @staticmethod
    def defines(params: ParamsMethods, controls: dict | None = None, medium: Medium | None = None) -> dict:
        """The #defines of the emission and trace programs for ``params``: the fixed
        ones, the ``medium``'s (``approx.medium_volumes.medium_defines``) and those the
        parameter table derives (``approx.params.defines``). Equal defines, equal
        programs: the renderer's cache key."""
        fixed = {"MAX_MATERIALS": MAX_MATERIALS, **START_OFFSET,
                 **controls_for(controls, "trace"), **(medium_defines(medium) if medium is not None else {})}
        table = table_defines(params, "trace")
        if "SPLAT_BEAMS" not in table:
            for name in ("BEAM_DIFFERENTIAL", "BEAM_BALANCED"):  # beam_width: beams only (one program for the others)
                table.pop(name, None)
        if carries_differentials(params):
            table["DIFFERENTIALS"] = 1  # emission and trace propagate them
        return {**fixed, **table}

    @staticmethod
    def programs(params: ParamsMethods, controls: dict | None = None, medium: Medium | None = None) -> dict:
        """name → (shader, defines) of every compute program a tracer for ``params``
        compiles: the constructor's list and the shader check's (scripts/check_shaders.py)."""
        defines = PhotonTracer.defines(params, controls, medium)
        beams = {name: 1 for name in ("SPLAT_BEAMS", "BEAM_DIFFERENTIAL") if name in defines}
        splits = {"FRESNEL_SPLITS": defines["FRESNEL_SPLITS"]} if "FRESNEL_SPLITS" in defines else {}
        out = {"emit": ("emission/emit.comp.glsl", defines), "trace": ("trace/trace.comp.glsl", defines),
               **MapPacker.programs(defines),
               "compact_count": ("splat/compact.comp.glsl", {"PASS_COUNT": 1, **beams, **splits}),
               "compact_scan": ("splat/compact.comp.glsl", {"PASS_SCAN": 1}),
               "compact_write": ("splat/compact.comp.glsl", {**splits, **(
                   {"SPLAT_ADAPTIVE": 1} if "SPLAT_ADAPTIVE" in defines
                   else {**beams, "BEAM_SIGMA_FLOOR": BEAM_SIGMA_FLOOR,
                         **({"BEAM_BALANCED": 1} if "BEAM_BALANCED" in defines else {})} if beams else {})})}
        if "EMISSION_ADAPTIVE" in defines:
            out["importance"] = ("emission/importance.comp.glsl", {})
        return out

    def check_limits(self, params: ApproxParams, *, keep_records: bool = False) -> None:
        """:func:`check_fits` with this tracer's GL driver."""
        check_fits(params, keep_records=keep_records, max_groups=self._max_groups, max_size=self._max_size)

    def _solid_angle_buffer(self, frustum, res: int) -> moderngl.Buffer:
        key = (res, round(frustum.tan_half, 12))
        if key not in self._solid_angles:
            for buf in self._solid_angles.values():
                buf.release()
            self._solid_angles = {key: self.ctx.buffer(frustum.texel_solid_angles(res).astype(np.float32).tobytes())}
        return self._solid_angles[key]

    def emit_photons(self, scene: Scene, frustum: LightFrustum, emission_map: LightMap, photon_res: int,
                     seed: int) -> moderngl.Buffer:
        """Photon buffer (photon_res² slots of PHOTON_DTYPE) after emission and the first
        interaction; ``emission_map`` is a :class:`approx.layers.LightMap` at photon_res.
        With adaptive emission the slots are drawn first (:meth:`draw_slots`). The buffer
        (and the differentials') is the pool's, kept across frames, when the tracer has
        one; else new (the caller releases the photons)."""
        prog = self.emit
        batches = self.splits + 1  # fresnel_splits: photon_res² slots per batch (scenes.splitting)
        n = batches * photon_res * photon_res
        photons = self._buffer("photons", n * PHOTON_DTYPE.itemsize)
        ior, _ = _materials(scene)
        emission_map.surface.use(location=0)
        emission_map.geometric.use(location=1)
        self._set_emission_map(prog, scene, frustum, photon_res)
        set_uniforms(prog, ior=ior, emission_geometric=1, seed=seed, sigma_t=tuple(scene.medium.sigma_t),
                     batch_slots=photon_res * photon_res)
        slots = self.draw_slots(scene, frustum, photon_res, seed) if self.emission_adaptive else None
        if slots is not None:
            slots.bind_to_storage_buffer(3)
        photons.bind_to_storage_buffer(0)
        self._solid_angle_buffer(frustum, photon_res).bind_to_storage_buffer(1)
        if self.carries_differentials:  # the frame's differentials, beside the photons (emission, trace, compaction)
            self._release_own(self.differentials, self.segment_differentials)  # the last frame's
            nbytes = n * DIFFERENTIAL_DTYPE.itemsize
            self.differentials = self._buffer("differentials", nbytes)
            self.differentials.bind_to_storage_buffer(2)
            self.segment_differentials = self._buffer("segment_differentials", nbytes) if self.beam_differential \
                else None
        self._bind_medium(prog)
        prog.run(group_x=math.ceil(photon_res / 8), group_y=math.ceil(photon_res / 8), group_z=batches)
        if slots is not None:
            slots.release()
        return photons

    def _set_emission_map(self, prog, scene, frustum, photon_res: int) -> None:
        """The uniforms of emission/map.glsl (the map bound at texture unit 0) and the spot."""
        set_uniforms(prog, **spot_constants(scene.light), emission_map=0, photon_res=photon_res,
                     tan_half=frustum.tan_half)
        uniform(prog, "light_basis").write(np.asarray(frustum.basis, np.float32).T.tobytes())

    def importance_map(self, scene: Scene, frustum: LightFrustum, photon_res: int) -> np.ndarray:
        """photon_res² float32, row-major: adaptive emission's importance per texel
        (emission/importance.comp.glsl) of the emission map bound at texture unit 0."""
        prog = cast(moderngl.ComputeShader, self.importance)  # adaptive emission's
        out = self.ctx.buffer(reserve=photon_res * photon_res * 4)
        self._set_emission_map(prog, scene, frustum, photon_res)
        out.bind_to_storage_buffer(0)
        self._solid_angle_buffer(frustum, photon_res).bind_to_storage_buffer(1)
        prog.run(group_x=math.ceil(photon_res / 8), group_y=math.ceil(photon_res / 8))
        importance = np.frombuffer(out.read(), np.float32).copy()
        out.release()
        return importance

    def draw_slots(self, scene: Scene, frustum: LightFrustum, photon_res: int, seed: int) -> moderngl.Buffer:
        """Adaptive emission's slots (``approx.emission.draw_slots`` of
        :meth:`importance_map`) as a storage buffer."""
        return self.ctx.buffer(draw_slots(self.importance_map(scene, frustum, photon_res), seed).tobytes())

    def kernel_source(self) -> moderngl.Buffer | None:
        """What the last step's kernels were made of, per photon slot (DIFFERENTIAL_DTYPE;
        this frame's buffer): with splat = adaptive the photons' differentials now (the
        footprint where they ended: compact.comp.glsl scales it), with beam_width =
        differential those at the start of the step's segment (the beam's footprint there
        and its rate along it); else None."""
        return self.segment_differentials if self.beam_differential else self.differentials if self.adaptive else None

    def map_buffer(self, light_maps: Sequence[LightMap], light_res: int) -> tuple:
        """:meth:`pack_maps` into new buffers (release them), and per map the exact (min,
        max) of its surface distances, None for an empty map (:func:`map_bounds`: waits
        for the GPU)."""
        buffers = self.pack_maps(light_maps, light_res)
        return buffers, map_bounds(buffers, len(light_maps))

    def pack_maps(self, light_maps: Sequence[LightMap], light_res: int) -> MapBuffers:
        """The light maps in the tracer's storage buffers (``approx.map_packing.MapPacker.pack``:
        the pool's, kept across frames, when the tracer has one; else new ones, release them)."""
        return self.packer.pack(light_maps, light_res)

    def trace_step(self, scene: Scene, frustum: LightFrustum, box: tuple[np.ndarray, np.ndarray],
                   map_texels: MapBuffers, light_res: int, photons: moderngl.Buffer,
                   records: moderngl.Buffer, count: int, step: int, seed: int,
                   objects_box: tuple[np.ndarray, np.ndarray] | None = None, records_offset: int = 0) -> None:
        """Advance every photon by one interaction step, writing one raw record per slot
        (``count`` of them from byte ``records_offset`` of ``records``).

        ``box``: (min, max) corners of the medium's box of ``scene``
        (``scenes.bounds.medium_bounds``), which photons do not leave;
        ``map_texels``: :meth:`pack_maps` of the layer maps (the tracer reads each map's
        distance range from it); ``objects_box``: (min, max) of the specular objects, used
        with the CLIP_TO_OBJECTS control. The step's loop work adds into slot ``step`` of
        :meth:`start_frame`'s counters (made there if this frame has none yet)."""
        prog = self.trace
        if objects_box is not None:
            pad = 1e-4 * float(np.linalg.norm(np.subtract(objects_box[1], objects_box[0])))
            set_uniforms(prog, objects_min=tuple(np.subtract(objects_box[0], pad)),
                         objects_max=tuple(np.add(objects_box[1], pad)))
        ior, absorption = _materials(scene)
        uniform(prog, "light_view_proj").write(gl_matrix(frustum.view_proj))
        if "light_basis" in prog:
            uniform(prog, "light_basis").write(np.asarray(frustum.basis, np.float32).T.tobytes())
        set_uniforms(prog, ior=ior, absorption=absorption, light_position=tuple(frustum.position), light_res=light_res,
                     texel_angle=2.0 * frustum.tan_half / light_res, sigma_t=tuple(scene.medium.sigma_t),
                     sigma_bar=scene.medium.sigma_bar, scene_min=tuple(box[0]),
                     scene_max=tuple(box[1]), seed=seed, step_index=step, photon_count=count,
                     batch_slots=count // (self.splits + 1))
        photons.bind_to_storage_buffer(0)
        records.bind_to_storage_buffer(1, offset=records_offset, size=count * RAW_RECORD_DTYPE.itemsize)
        map_texels.texels.bind_to_storage_buffer(2)
        map_texels.distances.bind_to_storage_buffer(3)
        map_texels.geometric.bind_to_storage_buffer(4)
        map_texels.ranges.bind_to_storage_buffer(10)
        if map_texels.primitive is not None:
            map_texels.primitive.bind_to_storage_buffer(5)
        if self.carries_differentials:
            cast(moderngl.Buffer, self.differentials).bind_to_storage_buffer(7)
        if self.segment_differentials is not None:
            self.segment_differentials.bind_to_storage_buffer(9)
        if map_texels.pyramid is not None:
            offsets, stride = pyramid_layout(light_res)
            map_texels.pyramid.bind_to_storage_buffer(6)
            set_uniforms(prog, pyramid_offset=offsets + [0] * (16 - len(offsets)), pyramid_stride=stride,
                         pyramid_top=len(offsets) - 1)
        if self.work is None or self.work.size < WORK_BYTES * step:
            self.start_frame(step)
        work = cast(moderngl.Buffer, self.work)
        work.bind_to_storage_buffer(8)
        self._bind_medium(prog)
        self.ctx.memory_barrier()  # the photons and maps the passes before wrote
        prog.run(group_x=math.ceil(count / 64))

    def use_medium(self, volumes: MediumVolumes, march_steps: int) -> None:
        """A heterogeneous medium's grid (this frame's ``approx.medium_volumes``) and the
        march's samples, for the emission and trace programs that follow."""
        self.volumes, self.march_steps = volumes, march_steps

    def _bind_medium(self, prog: moderngl.ComputeShader) -> None:
        if self.heterogeneous:
            if self.volumes is None:
                raise RuntimeError("a heterogeneous medium's tracer needs use_medium(volumes, march_steps) first")
            self.volumes.bind_grid(prog)
            set_uniforms(prog, march_steps=self.march_steps)

    def start_frame(self, steps: int) -> None:
        """Zero the trace loop's work counters of a frame of ``steps`` steps."""
        self._release_own(self.work)
        self.work = self._buffer("trace_work", WORK_BYTES * steps)
        self.work.write(bytes(self.work.size))

    def _buffer(self, name: str, nbytes: int) -> moderngl.Buffer:
        """The pool's buffer ``name``, or without a pool a new one."""
        return self.pool.buffer(name, nbytes) if self.pool is not None else self.ctx.buffer(reserve=nbytes)

    def _release_own(self, *buffers: moderngl.Buffer | None) -> None:
        """Release buffers :meth:`_buffer` made without a pool (a pool's stay its own)."""
        if self.pool is None:
            for buf in buffers:
                if buf is not None:
                    buf.release()

    def loop_work(self, steps: int) -> tuple:
        """The loop work of the frame's ``steps`` steps: (lookups, lockstep lookups, medium
        reads), each summed over the steps (reads the counters: waits for the GPU). Lookups:
        the map distances its photons looked up (every search loop iteration, whether it
        read memory or a register); lockstep: per subgroup its longest photon's lookups ×
        the subgroup's size (where the driver has subgroups; else the lookups); medium
        reads: a heterogeneous medium's samples of ρ (delta tracking's tentative
        collisions, the march's samples)."""
        work = np.frombuffer(cast(moderngl.Buffer, self.work).read(size=WORK_BYTES * steps),
                             np.uint32).reshape(steps, WORK_COUNTERS)
        return tuple(int(n) for n in work.sum(axis=0, dtype=np.uint64))

    def compact_splats(self, records: moderngl.Buffer, count: int, splats: moderngl.Buffer,
                       commands: moderngl.Buffer, params: ApproxParams | None = None, step: int = 1, *,
                       records_offset: int = 0,
                       balance: tuple[moderngl.Texture, CameraView] | None = None) -> None:
        """Gather the medium collisions of one step's records (``count`` of them from byte
        ``records_offset`` of ``records``) into ``splats`` (SPLAT_DTYPE rows, capacity
        ``count``) in photon order, and their number into ``commands``
        (:data:`SPLAT_COMMANDS`, the splat pass's indirect draws): counted, summed and
        placed on the GPU, never read here. With ``splat =
        adaptive`` each row carries its kernel width from the photons' differentials and
        ``params``' splat_radius and splat_footprints; with ``splat = beams`` the rows are
        the step's segments in the medium (BEAM_DTYPE), with beam_width = differential each
        carrying its kernel at its start and the kernel's rate along it
        (``approx.splat.beam_kernels``). With beam_width = balanced, ``balance`` (the
        balance map of the step's pilot, ``approx.splat.Splatter.balance_map``, and the
        camera's view) scales each beam's differential in place by the balance along it
        (splat/balance.glsl) before its kernel is made, the rows rewritten where the first
        compaction put them (its counts and offsets kept); None: the widths as they are (the
        pilot's)."""
        blocks = math.ceil(count / COMPACT_BLOCK)
        block_buf = self._buffer("compact_blocks", 4 * blocks)
        records.bind_to_storage_buffer(0, offset=records_offset, size=count * RAW_RECORD_DTYPE.itemsize)
        block_buf.bind_to_storage_buffer(1)
        batch = count // (self.splits + 1)  # photon_res²: one batch's slots (scenes.splitting)
        for prog in (self.compact_count, self.compact_write):
            set_uniforms(prog, step_index=step, batch_slots=batch, photon_count=count)
        self.ctx.memory_barrier()  # the records the trace wrote
        if balance is None or self.pool is None:  # a balanced rewrite keeps the first pass's offsets (pooled)
            self.compact_count.run(group_x=blocks)
            self.ctx.memory_barrier()
            commands.bind_to_storage_buffer(2)
            uniform(self.compact_scan, "block_count").value = blocks
            self.compact_scan.run(group_x=1)
            self.ctx.memory_barrier()
        splats.bind_to_storage_buffer(2)
        if self.adaptive or self.beam_differential:
            kernel_source = self.segment_differentials if self.beam_differential else self.differentials
            cast(moderngl.Buffer, kernel_source).bind_to_storage_buffer(3)
            p = cast("ApproxParams", params)  # given with splat = adaptive or differential beams (the docstring)
            set_uniforms(self.compact_write, splat_radius=p.splat_radius, splat_footprints=p.splat_footprints)
        if self.balanced:
            set_uniforms(self.compact_write, balance_apply=int(balance is not None))
            if balance is not None:
                balance_map, view = balance
                balance_map.use(location=0)
                set_uniforms(self.compact_write, balance_map=0)
                view.set_uniforms(self.compact_write)
        self.compact_write.run(group_x=blocks)
        self.ctx.memory_barrier()  # the splat pass draws from the rows and the commands written here
        self._release_own(block_buf)

    def release(self) -> None:
        self._release_own(self.work, self.differentials, self.segment_differentials)
        self.packer.release()
        for prog in (self.emit, self.trace, self.compact_count, self.compact_scan, self.compact_write):
            if prog is not None:
                prog.release()
        for buf in self._solid_angles.values():
            buf.release()


def read_raw_records(buf: moderngl.Buffer, count: int, offset: int = 0) -> np.ndarray:
    """``count`` raw records (RAW_RECORD_DTYPE) of ``buf`` from byte ``offset`` (waits for the GPU)."""
    return np.frombuffer(buf.read(size=count * RAW_RECORD_DTYPE.itemsize, offset=offset), dtype=RAW_RECORD_DTYPE)


def read_photons(buf: moderngl.Buffer, count: int) -> np.ndarray:
    return np.frombuffer(buf.read(size=count * PHOTON_DTYPE.itemsize), dtype=PHOTON_DTYPE)
