"""Light maps (paper Fig. 1A, 3, §4.2): depth (distance to the light, not z),
material id and normal of surfaces seen from the spot light.

Map m = 2·level + facing (0 front faces, 1 back faces); each texel holds
(distance, material, octahedral shading normal), 0 where empty, and a second
texture beside it the octahedral outward geometric normal of the triangle and
the triangle's primitive id + 1 (:class:`LightMap`). Strategies:

* ``threshold`` (the paper): the specular objects' extent along the spot axis is
  divided uniformly into ``layers`` levels; level i keeps the nearest front face
  and the nearest back face beyond threshold i (two passes).
* ``peel``: depth peeling per facing: level i holds the i-th front face and the
  i-th back face along each light ray (for closed meshes: the 2i-th and
  (2i+1)-th surfaces of classic peeling), so both strategies use 2·layers maps.
"""

from __future__ import annotations

import contextlib
from typing import TYPE_CHECKING, Any, NamedTuple

import moderngl
import numpy as np

from .context import bound
from .glsl import program, uniform
from .transforms import gl_matrix

if TYPE_CHECKING:
    from .light import LightFrustum
    from .resources import FrameResources

FRONT, BACK, BOTH = 1, -1, 0
# layers = auto (the presets best and beams): the most levels it peels, the table's ceiling
MOST_LEVELS = 8
# ... and the share of the first level's texels below which a level is negligible: the
# photons that need it are about that share of those that meet the objects, and at the
# paper's cost a level's maps and lookups are bought with photons. At 1% bunny and feline
# took a third level (1.7% and 1.3% of the texels) and lost one frame's error to it (0.26 →
# 0.30× and 0.14 → 0.18× the paper's at equal cost; docs/decisions.md "Layers from the scene")
LEVEL_SHARE = 0.05


class LightMap(NamedTuple):
    """One light map: ``surface`` RGBA32F (distance, material, octahedral shading
    normal; 0 = empty) and ``geometric``: the octahedral outward geometric normal, RG32F,
    or RGBA32F with the triangle's primitive id + 1 in its third channel (only the start
    rule ``id`` reads it: the wider target costs every frame's map passes)."""

    surface: moderngl.Texture
    geometric: moderngl.Texture

    def release(self) -> None:
        self.surface.release()
        self.geometric.release()


class LightMapRenderer:
    """Renders light maps of a :class:`SceneGeometry` into RGBA32F textures."""

    STAGES = ("layers/layer.vert.glsl", "layers/layer.frag.glsl")  # its one program, no defines

    def __init__(self, ctx: moderngl.Context, geometry):
        self.ctx = ctx
        self.geometry = geometry
        self.program = program(ctx, *self.STAGES)
        self.vao_specular = geometry.vertex_array(ctx, self.program, "specular")
        self.vao_diffuse = geometry.vertex_array(ctx, self.program, "diffuse")
        self._empty = ctx.texture((1, 1), 4, dtype="f4")  # bound as previous_map when unused
        self._empty.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._depth: dict[int, moderngl.Renderbuffer] = {}  # resolution -> depth renderbuffer, for every map of it
        # (samples, primitives) queries of the maps rendered since take_queries, unread (reading waits for the GPU)
        self.queries: list[moderngl.Query] = []
        self.layer_queries: list[moderngl.Query] = []  # the last render_layers' maps', in map order

    def take_queries(self) -> list[moderngl.Query]:
        """The (samples, primitives) queries of the maps rendered since the last call, to be
        read once the frame is done (a pass timer's queries cannot nest around them)."""
        queries, self.queries = self.queries, []
        return queries

    @property
    def layer_used(self) -> list[bool]:
        """Per map of the last :meth:`render_layers` (counted), whether any fragment was
        written (reads its occlusion queries: waits for the GPU)."""
        return [q.samples > 0 for q in self.layer_queries]

    def render_map(self, frustum: LightFrustum, res: int, *, facing: int = BOTH, threshold: float = -np.inf,
                   previous: moderngl.Texture | None = None, peel_epsilon: float = 0.0,
                   include_diffuse: bool = False, target: moderngl.Texture | None = None,
                   geometric: moderngl.Texture | None = None, count: bool = True,
                   pool: FrameResources | None = None, name: str = "map") -> moderngl.Texture:
        """One map at res×res; returns the texture (``target`` reused if given; with
        ``pool`` its framebuffer is ``pool``'s ``name``, kept for the next frame). The geometric normals (and primitive
        ids) go to ``geometric`` (res×res, :class:`LightMap`) when given.

        ``count``: an occlusion query counts the fragments that passed (0: the map is
        empty) and the primitives drawn, appended unread to ``self.queries``
        (:meth:`take_queries`); a display frame counts nothing."""
        ctx = self.ctx
        tex = target or ctx.texture((res, res), 4, dtype="f4")
        if pool is None:  # a pool's target already is (FrameResources)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        if pool is None and res not in self._depth:
            self._depth[res] = ctx.depth_renderbuffer((res, res))
        attachments = [tex] if geometric is None else [tex, geometric]
        if pool is not None:  # one depth buffer per resolution, shared by the maps (each clears it)
            fbo = pool.framebuffer(f"{name}_framebuffer", attachments, pool.depth(f"light_depth_{res}", (res, res)))
        else:
            fbo = ctx.framebuffer(color_attachments=attachments, depth_attachment=self._depth[res])
        prog = self.program
        uniform(prog, "light_view_proj").write(gl_matrix(frustum.view_proj))
        uniform(prog, "light_position").value = tuple(frustum.position)
        uniform(prog, "light_direction").value = tuple(frustum.direction)
        uniform(prog, "facing").value = facing
        uniform(prog, "threshold").value = float(max(threshold, -3.0e38))
        uniform(prog, "use_previous").value = previous is not None
        uniform(prog, "peel_epsilon").value = float(peel_epsilon)
        (previous or self._empty).use(location=0)
        uniform(prog, "previous_map").value = 0
        with bound(ctx, fbo):
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.disable(moderngl.CULL_FACE)
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            make = pool.query if pool is not None else ctx.query  # a pool's are handed back once read
            query = make(samples=True, primitives=True) if count else None
            with query if query is not None else contextlib.nullcontext():
                if self.vao_specular is not None:
                    self.geometry.use(prog, "specular")
                    self.vao_specular.render(moderngl.TRIANGLES)
                if include_diffuse and self.vao_diffuse is not None:
                    self.geometry.use(prog, "diffuse")
                    self.vao_diffuse.render(moderngl.TRIANGLES)
            ctx.disable(moderngl.DEPTH_TEST)
        if query is not None:
            self.queries.append(query)
        if pool is None:
            fbo.release()
        return tex

    def render_light_map(self, frustum: LightFrustum, res: int, *, primitive_ids: bool = True,
                         pool: FrameResources | None = None, name: str = "light_map", **filters: Any) -> LightMap:
        """One map with its geometric normals, and with the primitive ids when
        ``primitive_ids`` (``filters`` as :meth:`render_map`); its textures are ``pool``'s
        ``name`` (kept across frames) when given, else new ones (the caller releases them)."""
        if pool is not None:
            target = pool.texture(name, (res, res), 4)
            geometric = pool.texture(f"{name}_geometric", (res, res), 4 if primitive_ids else 2)
            return LightMap(self.render_map(frustum, res, geometric=geometric, target=target, pool=pool, name=name,
                                            **filters), geometric)
        geometric = self.ctx.texture((res, res), 4 if primitive_ids else 2, dtype="f4")
        geometric.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return LightMap(self.render_map(frustum, res, geometric=geometric, **filters), geometric)

    def thresholds(self, frustum: LightFrustum, layers: int) -> list[float]:
        """Level thresholds along the spot axis: uniform over the specular objects' extent.

        Level 0 keeps everything; level i > 0 starts at d_min + i·(d_max − d_min)/layers,
        with d the distance along the axis over the corners of the placed specular
        objects' bounding box.
        """
        lo_box, hi_box = self.geometry.objects_box
        corners = np.array([[x, y, z] for x in (lo_box[0], hi_box[0]) for y in (lo_box[1], hi_box[1])
                            for z in (lo_box[2], hi_box[2])])
        along = (corners - frustum.position) @ frustum.direction
        lo, hi = float(along.min()), float(along.max())
        return [-np.inf] + [lo + i * (hi - lo) / layers for i in range(1, layers)]

    def render_layers(self, frustum: LightFrustum, res: int, layers: int, strategy: str, *,
                      primitive_ids: bool = True, pool: FrameResources | None = None,
                      count: bool = True) -> list["LightMap"]:
        """The 2·layers maps in map order (2·level + facing), with the primitive ids when
        ``primitive_ids``; in ``pool``'s textures ``layer{m}`` when given.

        ``count``: also keeps each map's occlusion query in ``self.layer_queries``
        (:attr:`layer_used`: per map, whether any fragment was written)."""
        maps: list[LightMap] = []
        queries: list[moderngl.Query] = []
        peel_epsilon = 1e-5 * frustum.far
        thresholds = self.thresholds(frustum, layers)
        for level in range(layers):
            for k, facing in enumerate((FRONT, BACK)):
                name = f"layer{len(maps)}"
                if strategy == "threshold":
                    m = self.render_light_map(frustum, res, facing=facing, threshold=thresholds[level], pool=pool,
                                              name=name, primitive_ids=primitive_ids, count=count)
                else:
                    previous = maps[2 * (level - 1) + k].surface if level > 0 else None
                    m = self.render_light_map(frustum, res, facing=facing, previous=previous, peel_epsilon=peel_epsilon,
                                              pool=pool, name=name, primitive_ids=primitive_ids, count=count)
                maps.append(m)
                if count:
                    queries.append(self.queries[-1])
        self.layer_queries = queries
        return maps

    def depth_levels(self, frustum: LightFrustum, res: int, *, most: int = MOST_LEVELS) -> list[int]:
        """Per peeled level (the i-th front and the i-th back face along each light ray,
        ``peel``), the texels of res×res its two maps cover, from their occlusion queries
        (read here: waits for the GPU), ``most`` levels."""
        maps = self.render_layers(frustum, res, most, "peel", primitive_ids=False)
        try:
            self.queries = [q for q in self.queries if q not in self.layer_queries]  # read here, not by a frame
            samples = [q.samples for q in self.layer_queries]
        finally:
            for m in maps:
                m.release()
        return [samples[2 * i] + samples[2 * i + 1] for i in range(most)]

    def release(self) -> None:
        for vao in (self.vao_specular, self.vao_diffuse):
            if vao is not None:
                vao.release()
        self.program.release()
        self._empty.release()
        for depth in self._depth.values():
            depth.release()


def levels_needed(covered: list[int], share: float = LEVEL_SHARE) -> int:
    """layers = auto: the levels of :meth:`LightMapRenderer.depth_levels` (texels covered
    per peeled level) that hold at least ``share`` of the first level's texels, at least 1
    (peeled levels only shrink: the first below the share ends the count)."""
    first = covered[0] if covered else 0
    count = 1
    while count < len(covered) and first > 0 and covered[count] >= share * first:
        count += 1
    return count


def read_map(tex: moderngl.Texture) -> np.ndarray:
    """A light map as res×res×4 float32 (row 0 = bottom of the light image, GL order)."""
    w, h = tex.size
    return np.frombuffer(tex.read(), dtype=np.float32).reshape(h, w, 4).copy()


def decode_normals(encoded: np.ndarray) -> np.ndarray:
    """Octahedral-decoded unit normals from ...×2 encodings (numpy twin of common/octahedral.glsl)."""
    e = np.asarray(encoded, np.float64)
    n = np.concatenate([e, 1.0 - np.abs(e[..., :1]) - np.abs(e[..., 1:2])], axis=-1)
    neg = n[..., 2] < 0
    sign = np.where(n[..., :2] >= 0, 1.0, -1.0)
    folded = (1.0 - np.abs(n[..., 1::-1])) * sign
    n[..., :2] = np.where(neg[..., None], folded, n[..., :2])
    return n / np.linalg.norm(n, axis=-1, keepdims=True)
