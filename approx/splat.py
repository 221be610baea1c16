"""Photon splatting (paper §3, Eq. 5, §4.3): medium-collision photons as 3D
Gaussians, closed-form line integrals along pixel rays, additive float blending; or
(splat = beams) photon beams, each estimated along every pixel ray that passes near it
(splat/beam.*.glsl).

Accepts photons from any source: the GPU tracer's compact splat lists, or numpy
arrays (for instance from the exact photon tracer) via :func:`splats_from_arrays`.
"""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING, cast

import moderngl
import numpy as np

from volcaustics.scenes.formats import BEAM_DTYPE, SPLAT_DTYPE, STATUS_COLLIDED, STATUS_SURFACE, splatted_mask
from volcaustics.scenes.splitting import silent

from .context import bound
from .controls import EXACT_TRANSMITTANCE
from .glsl import attribute_layout, load_source, program, set_uniforms, uniform
from .params import differential_beams
from .resources import FrameResources
from .splat_modes import SPLAT_MODES, splat_mode

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from volcaustics.scenes.model import Medium

    from .camera_pass import CameraView
    from .medium_volumes import MediumVolumes
    from .params import ApproxParams

# Instance attributes of a splat (SPLAT_DTYPE, 48 bytes) and of a beam (BEAM_DTYPE, 48 bytes).
INSTANCE_PARTS = [("4f", "in_end"), ("4f", "in_dir_t"), ("4f", "in_power")]
BEAM_PARTS = [("4f", "in_start_length"), ("4f", "in_dir"), ("4f", "in_power")]
# splat = density: the pre-pass's grid cell (pixels a side): coarse enough that a cell holds
# several photons where the caustic is, fine enough to follow it; read bilinearly
DENSITY_CELL = 4
# splat = density: the narrowest kernel, in splat_radius. A screen-space density gives a
# photon near the camera a kernel a few pixels wide, a few millimetres in the medium: its
# 1/d² makes it a firefly (docs/decisions.md "Bandwidth from density")
DENSITY_FLOOR = 0.5
# beam_width = differential: the least σ0 a row carries (m), so that one whose footprint is 0
# where it starts (at a focus) still carries its own kernel (Beam.dir.w > 0; compact.comp.glsl)
BEAM_SIGMA_FLOOR = 1e-20
# beam_width = balanced: the pilot's pixels are this many of the image's a side (1/16 of
# the fragments: 6% more shaded beam fragments on sphere1, where 2 cost 32% and the cost
# match took 51 → 41 photons a side; the balance found the same, docs/decisions.md "Beam
# widths from the frame")
PILOT_DIVISOR = 4

# The splat pass's indirect draw commands (compact.comp.glsl PASS_SCAN): two
# DrawArraysIndirectCommand rows 5 uint32 apart (moderngl's render_indirect stride), the
# splats' quads (4 vertices) then their points (1 vertex), one instance a splat
SPLAT_COMMANDS = {"quads": 0, "points": 1, "stride": 20, "nbytes": 40}
SPLAT_COMMANDS_BINDING = 2  # the uniform block the DENSITY_IGNORED control reads the count from


def splat_commands(count: int) -> bytes:
    """The commands of ``count`` splats known on the host (splats from any source)."""
    return np.array([4, count, 0, 0, 0, 1, count, 0, 0, 0], np.uint32).tobytes()


def splats_from_arrays(end: ArrayLike, direction: ArrayLike, power: ArrayLike,
                       sigma: ArrayLike | None = None) -> np.ndarray:
    """Splat rows (SPLAT_DTYPE) from numpy arrays: end (N×3 collision points, m),
    direction (N×3 unit, propagation before scattering), power (N×3 W, RGB, after
    transmittance), and optionally each one's kernel standard deviation sigma (N, m;
    at least a pixel where it is drawn); without it every splat takes splat_radius."""
    return _rows(SPLAT_DTYPE, "center_status", end, STATUS_COLLIDED, direction, power, sigma)


def beams_from_arrays(start: ArrayLike, direction: ArrayLike, length: ArrayLike, power: ArrayLike,
                      sigma: ArrayLike | None = None) -> np.ndarray:
    """Beam rows (BEAM_DTYPE, splat = beams) from numpy arrays: start (N×3, m), direction
    (N×3 unit), length (N, m, to the next surface or the medium's end), power (N×3 W,
    RGB, at the start), and optionally each one's kernel standard deviation sigma (N, m);
    without it every beam takes splat_radius."""
    return _rows(BEAM_DTYPE, "start_length", start, length, direction, power, sigma)


def _rows(dtype: np.dtype, point: str, position: ArrayLike, w: ArrayLike, direction: ArrayLike,
          power: ArrayLike, sigma: ArrayLike | None) -> np.ndarray:
    """Rows of ``dtype`` (three vec4: ``point`` = position and ``w``, ``dir`` = direction
    and σ, ``power``) from numpy arrays, as float32."""
    position = np.asarray(position, np.float32).reshape(-1, 3)
    out = np.zeros(len(position), dtype=dtype)
    out[point][:, :3] = position
    out[point][:, 3] = np.asarray(w, np.float32).reshape(-1) if np.ndim(w) else w
    out["dir"][:, :3] = np.asarray(direction, np.float32).reshape(-1, 3)
    out["power"][:, :3] = np.asarray(power, np.float32).reshape(-1, 3)
    if sigma is not None:
        out["dir"][:, 3] = np.asarray(sigma, np.float32).reshape(-1)
    return out


def splatted(records: np.ndarray, params: ApproxParams) -> np.ndarray:
    """Which records (RECORD_DTYPE) a frame of ``params`` splats: its medium collisions, or
    with splat = beams its segments in the medium that reached a surface or the medium's
    end, but for a split batch's share of another's (``scenes.splitting.silent``): what
    splat/compact.comp.glsl gathers."""
    keep = splatted_mask(records["inside"], records["status"], splat_mode(params).beams)
    if params.fresnel_splits:
        keep &= ~silent(records["photon"], records["step"], params.fresnel_splits, params.photon_res**2)
    return keep


def record_splats(records: np.ndarray, splat: str) -> np.ndarray:
    """The rows the splatter draws for :func:`splatted` records (RECORD_DTYPE):
    SPLAT_DTYPE from each collision, or with ``splat`` = beams BEAM_DTYPE from each
    segment's start, direction, length (to its hit, or the length searched) and power
    at its start."""
    if SPLAT_MODES[splat].beams:
        length = np.where(records["status"] == STATUS_SURFACE, records["t"], records["search_length"])
        return beams_from_arrays(records["start"], records["direction"], length, records["power_start"])
    return splats_from_arrays(records["end"], records["direction"], records["power"])


def adaptive_sigma(footprint: ArrayLike, params: ApproxParams) -> np.ndarray:
    """The kernel widths (m, float32) that splat = adaptive gives photons of differential
    ``footprint`` (m): numpy twin of splat/compact.comp.glsl, bit for bit
    (splat_footprints × |footprint| within [splat_radius/16, 4·splat_radius])."""
    radius = np.float32(params.splat_radius)
    scaled = np.float32(params.splat_footprints) * np.abs(np.asarray(footprint, np.float32))
    return np.clip(scaled, radius / np.float32(16.0), np.float32(4.0) * radius)


def beam_kernels(footprint: ArrayLike, rate: ArrayLike, params: ApproxParams) -> tuple[np.ndarray, np.ndarray]:
    """(σ0, its rate) per beam (m and m/m, float32) that beam_width = differential gives
    segments starting with differential ``footprint`` (m, signed) changing at ``rate``
    along them: numpy twin of splat/compact.comp.glsl, bit for bit (σ0 = |a|, a =
    splat_footprints × footprint, at least BEAM_SIGMA_FLOOR; the rate sign(a) ×
    splat_footprints × rate, so that |σ0 + rate·s| is the footprint's at s; the splatter
    clamps it, splat/beam_width.glsl)."""
    scale = np.float32(params.splat_footprints)
    a = scale * np.asarray(footprint, np.float32)
    sigma0 = np.maximum(np.abs(a), np.float32(BEAM_SIGMA_FLOOR))
    return sigma0, np.where(a < 0, -scale, scale) * np.asarray(rate, np.float32)


def record_kernels(records: np.ndarray, params: ApproxParams) -> np.ndarray | None:
    """Per record (RECORD_DTYPE) the kernel its row was splatted with, N×2 float32 (the
    row's σ and its rate along a beam: SPLAT_DTYPE/BEAM_DTYPE dir.w and power.w): splat =
    adaptive the collision's σ (rate 0), beams with beam_width = differential
    :func:`beam_kernels`; None where every row takes splat_radius."""
    if splat_mode(params).differential_width:
        sigma = adaptive_sigma(records["footprint"], params)
        return np.stack([sigma, np.zeros_like(sigma)], axis=1)
    if differential_beams(params):
        return np.stack(beam_kernels(records["footprint"], records["footprint_rate"], params), axis=1)
    return None


def with_kernels(rows: np.ndarray, kernels: ArrayLike) -> np.ndarray:
    """``rows`` (SPLAT_DTYPE or BEAM_DTYPE) carrying ``kernels`` (N×2: σ as dir.w, its rate
    along a beam as power.w; :func:`record_kernels`), a copy."""
    kernels = np.asarray(kernels, np.float32).reshape(-1, 2)
    out = rows.copy()
    out["dir"][:, 3] = kernels[:, 0]
    out["power"][:, 3] = kernels[:, 1]
    return out


def _add_into(ctx, fbo: moderngl.Framebuffer, vao, mode, commands: moderngl.Buffer, command: str) -> None:
    """Draw ``vao`` as ``commands``' row ``command`` (:data:`SPLAT_COMMANDS`: the count
    stays on the GPU) added into ``fbo``'s image (additive float blending)."""
    with bound(ctx, fbo):
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        ctx.blend_equation = moderngl.FUNC_ADD
        vao.render_indirect(commands, mode, count=1, first=SPLAT_COMMANDS[command])
        ctx.disable(moderngl.BLEND)


class Splatter:
    """Splat program for one phase function and splat mode (``adaptive``: each splat's
    own kernel, where it has one; ``density``: each splat's kernel from the photons per
    cell of a pre-pass, ``splat_neighbours`` of them within it; ``beams``: the rows are
    beams, BEAM_DTYPE; ``balanced``: beams whose widths a pilot balances
    (:meth:`balance_map`); ``controls``: a test's changes to the splat program)."""

    def __init__(self, ctx: moderngl.Context, medium, *, adaptive: bool = False, density: bool = False,
                 beams: bool = False, balanced: bool = False, controls: dict | None = None,
                 pool: FrameResources | None = None):
        self.ctx = ctx
        self.beams = beams
        programs = self.programs(medium, adaptive=adaptive, density=density, beams=beams, balanced=balanced,
                                 controls=controls)
        (vertex, fragment), defines = programs["splat"]
        self.program = program(ctx, vertex, fragment, defines)
        self.pilot_program = self.balance_program = None
        if balanced:
            (vertex, fragment), pilot = programs["pilot"]
            self.pilot_program = program(ctx, vertex, fragment, pilot)
            (vertex, fragment), balance = programs["balance"]
            self.balance_program = program(ctx, vertex, fragment, balance)
        self.density_program = None
        if density:
            (vertex, fragment), _ = programs["density"]
            self.density_program = program(ctx, vertex, fragment)
        self.defines = programs["splat"][1]
        self.volumes: MediumVolumes | None = None  # a heterogeneous medium's this frame (the renderer's)
        self.march_steps = 16                      # ... and its beams' march (the renderer's params)
        self.widths_program: moderngl.Program | None = None  # the widths pass (density_widths), when first used
        corners = np.array([[-1, -1], [1, -1], [-1, 1], [1, 1]], np.float32)
        self.corners = ctx.buffer(corners.tobytes())
        # where its framebuffers, vertex arrays and pre-pass grid live across frames: the
        # renderer's (one pool, so that what they name is held or tracked there) or its own
        self.pool = pool or FrameResources(ctx)
        self._own_pool = pool is None
        self.pool.track(self.program, self.corners, *(p for p in (self.density_program, self.pilot_program,
                                                                  self.balance_program) if p is not None))

    @staticmethod
    def programs(medium: Medium, *, adaptive: bool = False, density: bool = False, beams: bool = False,
                 balanced: bool = False, controls: dict | None = None) -> dict:
        """name → (shader stages, defines) of every program a Splatter compiles: the
        constructor's list and the shader check's (scripts/check_shaders.py); "widths"
        (a vertex stage alone, by transform feedback) is compiled when first used."""
        defines: dict[str, object] = {"PHASE_G": repr(float(medium.phase.g))} if medium.phase.kind == "hg" else {}
        if medium.is_heterogeneous:  # ρ and the transmittance volumes (approx.medium_volumes)
            defines["HETEROGENEOUS"] = 1
        # the decomposition's exact transmittance goes to every mode; a test's faults to the density and beam modes
        defines.update({k: v for k, v in (controls or {}).items() if k in EXACT_TRANSMITTANCE})
        if adaptive or density:  # per-splat kernels (SPLAT_DTYPE dir.w or the density), integrated over each pixel
            defines["SPLAT_ADAPTIVE"] = 1
        if density:
            defines.update({"SPLAT_DENSITY": 1, **(controls or {})})
        if beams:
            stages = ("splat/beam.vert.glsl", "splat/beam.frag.glsl")
            beam_defines = {**defines, **(controls or {})}
            out_beams = {"splat": (stages, beam_defines)}
            if balanced:
                out_beams["pilot"] = (stages, {**beam_defines, "BEAM_PILOT": 1})
                out_beams["balance"] = (("shade/fullscreen.vert.glsl", "splat/balance.frag.glsl"),
                                        {k: v for k, v in (controls or {}).items() if k.startswith("BALANCE_")})
            return out_beams
        out: dict[str, tuple[tuple[str, ...], dict]] = {
            "splat": (("splat/splat.vert.glsl", "splat/splat.frag.glsl"), defines)}
        if density:
            out["density"] = (("splat/density.vert.glsl", "splat/density.frag.glsl"), {})
            out["widths"] = (("splat/widths.vert.glsl",), defines)
        return out

    def density_grid(self, splats: moderngl.Buffer, commands: moderngl.Buffer, view: CameraView,
                     target: moderngl.Texture | None = None) -> moderngl.Texture:
        """The pre-pass: photons per DENSITY_CELL² cell of the image (R32F, bilinear) of
        the splats ``commands`` counts (:data:`SPLAT_COMMANDS`), into ``target`` (a
        texture of :meth:`grid_size`) or the splatter's own grid, kept across frames."""
        ctx, prog = self.ctx, cast(moderngl.Program, self.density_program)  # a density Splatter's
        grid = target or self.pool.texture("density_grid", self.grid_size(view), 1, linear=True)
        fbo = self.pool.framebuffer("density_grid_framebuffer", [grid])
        fbo.clear(0.0, 0.0, 0.0, 0.0)  # counts from 0; no photons (a step that splatted none): every cell 0
        view.set_uniforms(prog)
        fmt, names = attribute_layout(prog, INSTANCE_PARTS, per_instance=True)
        vao = self.pool.vertex_array("density_vertex_array", prog, [(splats, fmt, *names)])
        _add_into(ctx, fbo, vao, moderngl.POINTS, commands, "points")
        return grid

    @staticmethod
    def grid_size(view: CameraView) -> tuple[int, int]:
        """(width, height) of the density pre-pass's grid for ``view``."""
        return -(-view.width // DENSITY_CELL), -(-view.height // DENSITY_CELL)

    def _use_density(self, prog, grid: moderngl.Texture, commands: moderngl.Buffer, splat_neighbours: int) -> None:
        """Bind the density pre-pass ``grid`` of the splats ``commands`` counts for ``prog``
        (texture unit 1, the width's uniforms, splat/density_width.glsl; the count itself
        only for the DENSITY_IGNORED control, read on the GPU)."""
        grid.use(location=1)
        set_uniforms(prog, density=1, density_cell=float(DENSITY_CELL), splat_neighbours=float(splat_neighbours),
                     density_floor=DENSITY_FLOOR)
        if "SplatCommands" in prog:
            commands.bind_to_uniform_block(SPLAT_COMMANDS_BINDING)
            prog["SplatCommands"].binding = SPLAT_COMMANDS_BINDING

    def density_widths(self, splats: moderngl.Buffer, count: int, field: moderngl.Buffer, field_count: int,
                       view: CameraView, splat_radius: float, splat_neighbours: int = 16) -> np.ndarray:
        """splat = density: the kernel σ (m, float32, one per row; 0 for a row that is not
        a collision) that :meth:`splat` gives each of ``count`` splats when the density
        pre-pass counts the ``field_count`` splats of ``field`` instead of their own: the
        same pre-pass and width (splat/density_width.glsl), by transform feedback."""
        if self.density_program is None:
            raise ValueError("density_widths: a Splatter made with density=True has them")
        ctx = self.ctx
        if self.widths_program is None:
            self.widths_program = ctx.program(vertex_shader=load_source("splat/widths.vert.glsl", self.defines),
                                              varyings=("out_sigma",))
        prog = self.widths_program
        view.set_uniforms(prog)
        set_uniforms(prog, splat_radius=float(splat_radius), pixel_angle=2.0 / (float(view.proj[1, 1]) * view.height))
        commands = ctx.buffer(splat_commands(field_count))
        out = ctx.buffer(reserve=4 * max(count, 1))
        fmt, names = attribute_layout(prog, INSTANCE_PARTS)
        vao = ctx.vertex_array(prog, [(splats, fmt, *names)])
        try:
            grid = self.density_grid(field, commands, view)
            self._use_density(prog, grid, commands, splat_neighbours)
            vao.transform(out, moderngl.POINTS, vertices=count)
            return np.frombuffer(out.read(), np.float32)[:count].copy()
        finally:
            for r in (vao, out, commands):
                r.release()

    def splat(self, splats: moderngl.Buffer, commands: moderngl.Buffer, view: CameraView, medium: Medium,
              splat_radius: float, scene_distance: moderngl.Texture, target: moderngl.Texture,
              splat_neighbours: int = 16, grid: moderngl.Texture | None = None, name: str = "splat") -> None:
        """Add the splats ``commands`` counts (:data:`SPLAT_COMMANDS`; SPLAT_DTYPE rows of
        ``splats``; a beams splatter's: BEAM_DTYPE) into ``target`` (RGBA32F), drawn
        indirectly (the count stays on the GPU); each collision weighs sigma_s / sigma_bar
        (the tracer's free-flight rate), a beam sigma_s per metre. Density splats take
        ``grid`` (:meth:`density_grid` of these splats) or make their own. ``name``: the
        target's framebuffer in the pool (one per target the caller keeps)."""
        sigma_bar = medium.sigma_bar
        if sigma_bar <= 0:
            return
        prog = self.program
        if self.density_program is not None and grid is None:
            grid = self.density_grid(splats, commands, view)
        self._estimate(prog, view, medium, splat_radius, scene_distance)
        if grid is not None:
            self._use_density(prog, grid, commands, splat_neighbours)
        self._add(prog, "splat_vertex_array", splats, commands, target, name)

    def _estimate(self, prog: moderngl.Program, view: CameraView, medium: Medium, splat_radius: float,
                  scene_distance: moderngl.Texture) -> None:
        """Set what the splat estimate of ``prog`` reads: the view, the medium, the kernel
        and the G-buffer's distances (texture unit 0)."""
        view.set_uniforms(prog)
        if "HETEROGENEOUS" in self.defines:
            if self.volumes is None:
                raise RuntimeError("a heterogeneous medium's splats need the frame's volumes (Splatter.volumes)")
            self.volumes.bind(prog, self.march_steps)
            if self.beams and "EXACT_EYE" in self.defines:
                self.volumes.bind_eye_knots(prog, view.eye, view.view_proj, (view.width, view.height))
        if self.beams:
            uniform(prog, "sigma_s").value = tuple(medium.sigma_s)
        else:
            uniform(prog, "scatter_weight").value = tuple(s / medium.sigma_bar for s in medium.sigma_s)
        uniform(prog, "sigma_t").value = tuple(medium.sigma_t)
        set_uniforms(prog, splat_radius=float(splat_radius),
                     pixel_angle=2.0 / (float(view.proj[1, 1]) * view.height))
        scene_distance.use(location=0)
        uniform(prog, "scene_distance").value = 0

    def _add(self, prog: moderngl.Program, vertex_array: str, splats: moderngl.Buffer, commands: moderngl.Buffer,
             target: moderngl.Texture, name: str) -> None:
        """Draw the rows ``commands`` counts with ``prog`` (its uniforms set) into ``target``
        (its framebuffer the pool's ``name``), through the pool's ``vertex_array``."""
        fmt, names = attribute_layout(prog, BEAM_PARTS if self.beams else INSTANCE_PARTS, per_instance=True)
        content = [(self.corners, "2f", "in_corner"), (splats, fmt, *names)]
        vao = self.pool.vertex_array(vertex_array, prog, content)
        fbo = self.pool.framebuffer(f"{name}_framebuffer", [target])
        _add_into(self.ctx, fbo, vao, moderngl.TRIANGLE_STRIP, commands, "quads")

    def balance_map(self, beams: moderngl.Buffer, commands: moderngl.Buffer, view: CameraView, medium: Medium,
                    splat_radius: float, scene_distance: moderngl.Texture) -> moderngl.Texture:
        """beam_width = balanced: the pilot of the beams ``commands`` counts (BEAM_DTYPE rows
        at their differential widths, estimated at 1/PILOT_DIVISOR of the view's pixels a
        side) and from it the balance map (R32F, bilinear, the pilot's size: per pixel ln
        of the width factor that balances the blur's bias against the noise there,
        splat/balance.frag.glsl), the pool's, kept across frames. Nothing is read."""
        ctx = self.ctx
        prog, balance = cast(moderngl.Program, self.pilot_program), cast(moderngl.Program, self.balance_program)
        pilot_view = copy.copy(view)  # the same projection at coarser pixels
        pilot_view.width, pilot_view.height = -(-view.width // PILOT_DIVISOR), -(-view.height // PILOT_DIVISOR)
        size = (pilot_view.width, pilot_view.height)
        pilot = self.pool.texture("balance_pilot", size)
        self.pool.framebuffer("balance_pilot_framebuffer", [pilot]).clear(0.0, 0.0, 0.0, 0.0)
        self._estimate(prog, pilot_view, medium, splat_radius, scene_distance)
        set_uniforms(prog, gbuffer_step=float(PILOT_DIVISOR))
        self._add(prog, "balance_pilot_vertex_array", beams, commands, pilot, "balance_pilot")
        out = self.pool.texture("balance_map", size, 1, linear=True)
        pilot.use(location=0)
        uniform(balance, "pilot").value = 0
        fbo = self.pool.framebuffer("balance_map_framebuffer", [out])
        vao = self.pool.vertex_array("balance_vertex_array", balance, [])
        with bound(ctx, fbo):
            vao.render(moderngl.TRIANGLES, vertices=3)
        return out

    def release(self) -> None:
        if self._own_pool:
            self.pool.release()
        self.program.release()
        for prog in (self.density_program, self.widths_program, self.pilot_program, self.balance_program):
            if prog is not None:
                prog.release()
        self.corners.release()
