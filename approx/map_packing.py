"""The light maps as the tracer reads them: each frame's layer maps (textures) packed into
storage buffers on the GPU, with every map's distance range reduced there, and for the
``hiz`` search a min–max pyramid over each map's distances (paper §4.2's maps, laid out
for the compute tracer, ``approx.trace``)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, NamedTuple, cast

import moderngl
import numpy as np

from .glsl import set_uniforms, uniform

if TYPE_CHECKING:
    from .layers import LightMap

PACK = {"PACK_BLOCK": 256, "PACK_TEXELS": 4}  # trace/pack_distances.comp.glsl: invocations a group, texels each


class MapBuffers(NamedTuple):
    """The light maps as the tracer reads them (storage buffers, map-major, rows
    bottom-up): every texel (RGBA32F: distance, material, octahedral shading normal),
    the distances alone (R32F), the octahedral geometric normals (2 floats), for the
    start rule ``id`` only the primitive ids + 1 (R32F; 0 = none) and for the ``hiz``
    search only the min–max pyramid (:func:`pyramid_layout`); None where not needed;
    and per map the exact range of its surface distances, two uint32 (the float bits of
    the min and the max; max 0: an empty map), which the tracer reads on the GPU
    (:func:`map_bounds` reads it on the host)."""

    texels: moderngl.Buffer
    distances: moderngl.Buffer
    geometric: moderngl.Buffer
    primitive: moderngl.Buffer | None
    pyramid: moderngl.Buffer | None
    ranges: moderngl.Buffer

    def release(self) -> None:
        for buf in self:
            if buf is not None:
                buf.release()


def pyramid_cells(light_res: int, level: int) -> int:
    """Cells per side of a min–max pyramid level (cell = texel >> level; as cells() of
    trace/pyramid.comp.glsl)."""
    return ((light_res - 1) >> level) + 1


def pyramid_layout(light_res: int) -> tuple:
    """The min–max pyramid of one map (trace/pyramid.comp.glsl): level L >= 1 has
    :func:`pyramid_cells` cells per side, the top level one; returns (offsets, stride):
    the cell offset of each level within a map's block (index L; 0 unused) and the
    cells of one map's block."""
    offsets, total, level = [0], 0, 1
    while True:
        offsets.append(total)
        n = pyramid_cells(light_res, level)
        total += n * n
        if n == 1:
            return offsets, total
        level += 1


def map_bounds(buffers: MapBuffers, maps: int) -> list:
    """Per map of ``buffers`` the exact (min, max) of its surface distances (m), None for
    an empty map (reads the GPU's reduction: waits for it)."""
    bits = np.frombuffer(buffers.ranges.read(size=8 * maps), np.uint32).reshape(-1, 2)
    values = bits.view(np.float32)
    return [None if b[1] == 0 else (float(v[0]), float(v[1])) for b, v in zip(bits, values)]


class MapPacker:
    """Packs a frame's light maps (``pack``: the ``pack`` program, and for the ``hiz``
    search the ``pyramid`` program) into buffers from ``buffer(name, bytes)`` (a
    renderer's pool, kept across frames, or new ones); ``primitive``: keep the primitive
    ids too (the ``id`` start rule)."""

    def __init__(self, ctx: moderngl.Context, pack: moderngl.ComputeShader, pyramid: moderngl.ComputeShader | None,
                 buffer: Callable[[str, int], moderngl.Buffer], *, primitive: bool):
        self.ctx, self.program, self.pyramid, self.buffer, self.primitive = ctx, pack, pyramid, buffer, primitive

    @staticmethod
    def programs(defines: dict) -> dict:
        """name → (shader, defines) of the packing programs a tracer with ``defines`` compiles."""
        out = {"pack": ("trace/pack_distances.comp.glsl",
                        {**PACK, **({"PACK_PRIMITIVE": 1} if "START_RULE_ID" in defines else {})})}
        if "SEARCH_HIZ" in defines:
            out["pyramid"] = ("trace/pyramid.comp.glsl", {})
        return out

    def pack(self, light_maps: Sequence[LightMap], light_res: int) -> MapBuffers:
        """The light maps (:class:`approx.layers.LightMap`) copied into storage buffers
        (:class:`MapBuffers`, from the packer's ``buffer``), with the range of each map's
        distances reduced on the GPU, never read here. With the ``hiz`` search the min–max
        pyramid is built here too (once per frame, like the maps)."""
        count = light_res * light_res
        n = len(light_maps)
        buffer = self.buffer
        texels, distances = buffer("map_texels", 16 * count * n), buffer("map_distances", 4 * count * n)
        geometric = buffer("map_geometric", 8 * count * n)
        primitive = buffer("map_primitive", 4 * count * n) if self.primitive else None
        init = np.zeros((n, 2), np.uint32)
        init[:, 0] = 0xFFFFFFFF
        ranges = buffer("map_ranges", init.nbytes)
        ranges.write(init.tobytes())
        texels.bind_to_storage_buffer(0)
        distances.bind_to_storage_buffer(1)
        ranges.bind_to_storage_buffer(2)
        geometric.bind_to_storage_buffer(3)
        if primitive is not None:
            primitive.bind_to_storage_buffer(4)
        uniform(self.program, "res").value = light_res
        uniform(self.program, "map_texture").value = 0
        uniform(self.program, "geometric_texture").value = 1
        for m, light_map in enumerate(light_maps):
            light_map.surface.use(location=0)
            light_map.geometric.use(location=1)
            uniform(self.program, "map_index").value = m
            self.program.run(group_x=math.ceil(count / (PACK["PACK_BLOCK"] * PACK["PACK_TEXELS"])))
        pyramid = None
        if self.pyramid is not None:
            pyramid = buffer("map_pyramid", 8 * pyramid_layout(light_res)[1] * n)
            self._build_pyramid(distances, pyramid, n, light_res)
        return MapBuffers(texels, distances, geometric, primitive, pyramid, ranges)

    def _build_pyramid(self, distances: moderngl.Buffer, pyramid: moderngl.Buffer, maps: int,
                       light_res: int) -> None:
        """The min–max pyramid of every map (trace/pyramid.comp.glsl) into ``pyramid``, level by level."""
        offsets, stride = pyramid_layout(light_res)
        distances.bind_to_storage_buffer(0)
        pyramid.bind_to_storage_buffer(1)
        prog = cast(moderngl.ComputeShader, self.pyramid)  # search = hiz's
        set_uniforms(prog, light_res=light_res, map_stride=stride)
        for level in range(1, len(offsets)):
            cells = pyramid_cells(light_res, level)
            set_uniforms(prog, level=level, source_offset=offsets[level - 1], target_offset=offsets[level])
            prog.run(group_x=math.ceil(cells / 8), group_y=math.ceil(cells / 8), group_z=maps)
            self.ctx.memory_barrier()  # the next level (and the trace) read what this one wrote

    def release(self) -> None:
        for prog in (self.program, self.pyramid):
            if prog is not None:
                prog.release()
