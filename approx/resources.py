"""GL objects a frame writes into, kept across frames (the GPU is fed, not waited on:
resources live across frames).

A :class:`FrameResources` hands out textures, buffers, depth buffers, framebuffers and
vertex arrays by name: made the first time a name is asked for, reused while what was
asked (size, format, attachments, program) stays the same, and remade when it changes, so
a renderer drawing frame after frame of one scene and one set of parameters makes no GL
object after its first frame (``made`` counts them: the display frame's test reads it).
"""

from __future__ import annotations

from collections.abc import Sequence

import moderngl


class FrameResources:
    """Named GL objects of one context, kept until the spec asked for changes or
    :meth:`release`."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._items: dict[str, tuple[tuple, object, int]] = {}  # name → (spec, object, serial)
        self._serials: dict[int, int] = {}  # id(object) → serial, for what depends on it
        self._tracked: list[object] = []  # objects the caller keeps, referenced here so that their ids stay theirs
        self.made = 0  # GL objects made so far (each remade one counts again)
        # queries read and handed back, by their kinds: moderngl's queries cannot be deleted, so they are reused
        self._queries: dict[tuple, list[moderngl.Query]] = {}
        self._query_kinds: dict[int, tuple] = {}
        self._next = 0  # serials

    def _get(self, name: str, spec: tuple, make):
        item = self._items.get(name)
        if item is not None and item[0] == spec:
            return item[1]
        if item is not None:
            self._drop(name)
        obj = make()
        self.made += 1
        self._items[name] = (spec, obj, self._serial(obj))
        return obj

    def _serial(self, obj: object) -> int:
        self._next += 1
        self._serials[id(obj)] = self._next
        return self._next

    def track(self, *objects: object) -> None:
        """Let objects the caller keeps alive and unchanged (programs, constant buffers) be
        part of a kept object's spec (:meth:`key`); an object neither held nor tracked
        makes what depends on it anew on every call."""
        for obj in objects:
            if id(obj) not in self._serials:
                self._tracked.append(obj)
                self._serial(obj)

    def _drop(self, name: str) -> None:
        _, obj, _ = self._items.pop(name)
        self._serials.pop(id(obj), None)
        obj.release()  # type: ignore[attr-defined]  # every kind held here has release()

    def key(self, obj: object) -> tuple:
        """What identifies ``obj`` in a dependent object's spec: its serial when it is
        held or tracked here (a remade texture is a new serial even where GL reuses its
        name); else a token never seen before, so the dependent is made anew (an id could
        be a dead object's)."""
        serial = self._serials.get(id(obj))
        if serial is None:
            self._next += 1
            return ("untracked", self._next)
        return ("serial", serial)

    def texture(self, name: str, size: tuple[int, int], components: int = 4, *, dtype: str = "f4",
                linear: bool = False) -> moderngl.Texture:
        """A ``size`` texture (width, height) of ``components`` ``dtype`` channels, nearest
        (``linear``: bilinear) filtered, clamped at its edges. Its content is whatever the
        last frame left: the pass that writes it clears it."""
        def make() -> moderngl.Texture:
            tex = self.ctx.texture(size, components, dtype=dtype)
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR) if linear else (moderngl.NEAREST, moderngl.NEAREST)
            tex.repeat_x = tex.repeat_y = False
            return tex
        return self._get(name, ("texture", tuple(size), components, dtype, linear), make)

    def texture3d(self, name: str, size: tuple[int, int, int], components: int = 1, *,
                  dtype: str = "f4") -> moderngl.Texture3D:
        """A ``size`` 3D texture (width, height, depth) of ``components`` ``dtype`` channels,
        trilinear filtered, clamped at its edges; its content is the last frame's."""
        def make() -> moderngl.Texture3D:
            tex = self.ctx.texture3d(size, components, dtype=dtype)
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = tex.repeat_z = False
            return tex
        return self._get(name, ("texture3d", tuple(size), components, dtype), make)

    def buffer(self, name: str, nbytes: int) -> moderngl.Buffer:
        """A buffer of at least ``nbytes`` (never 0: GL refuses empty storage)."""
        return self._get(name, ("buffer", max(int(nbytes), 4)), lambda: self.ctx.buffer(reserve=max(int(nbytes), 4)))

    def depth(self, name: str, size: tuple[int, int]) -> moderngl.Renderbuffer:
        return self._get(name, ("depth", tuple(size)), lambda: self.ctx.depth_renderbuffer(size))

    def framebuffer(self, name: str, color: Sequence[moderngl.Texture],
                    depth: moderngl.Renderbuffer | None = None) -> moderngl.Framebuffer:
        """A framebuffer of ``color`` attachments (and ``depth``), remade when any of them is."""
        spec = ("framebuffer", tuple(self.key(c) for c in color), None if depth is None else self.key(depth))
        return self._get(name, spec, lambda: self.ctx.framebuffer(color_attachments=list(color),
                                                                  depth_attachment=depth))

    def vertex_array(self, name: str, program: moderngl.Program, content: Sequence[tuple]) -> moderngl.VertexArray:
        """``ctx.vertex_array(program, content)``, remade when the program, a buffer or a
        format in ``content`` changes."""
        spec = ("vertex_array", self.key(program),
                tuple((self.key(entry[0]), *entry[1:]) for entry in content))
        return self._get(name, spec, lambda: self.ctx.vertex_array(program, list(content)))

    def query(self, **kinds: bool) -> moderngl.Query:
        """A query of ``kinds`` (moderngl's ``ctx.query`` keywords), one handed back by
        :meth:`recycle` when there is one: a measured frame's queries are read after the
        frame, then reused by the next (moderngl cannot delete a query)."""
        key = tuple(sorted(k for k, v in kinds.items() if v))
        free = self._queries.setdefault(key, [])
        if free:
            return free.pop()
        query = self.ctx.query(**kinds)
        self.made += 1
        self._query_kinds[id(query)] = key
        return query

    def recycle(self, queries: Sequence[moderngl.Query]) -> None:
        """Hand back queries of :meth:`query` whose results were read."""
        for query in queries:
            key = self._query_kinds.get(id(query))
            if key is not None:
                self._queries[key].append(query)

    def release(self) -> None:
        # dependents first (framebuffers and vertex arrays name the textures and buffers)
        for kind in ("vertex_array", "framebuffer", None):
            for name in [n for n, (spec, _, _) in self._items.items() if kind is None or spec[0] == kind]:
                self._drop(name)
