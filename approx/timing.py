"""Per-pass GPU times: timer queries where the driver supports them, else
``ctx.finish()`` and a wall clock (llvmpipe answers 4294967295 to timer queries,
a sentinel that is never reported); and per pass the fragments it wrote (a GL
samples-passed query: fragments that reach the framebuffer, so a fragment shader's
discards are not counted), the fragments it shaded (discards included:
``approx.invocations``, where the driver has pipeline statistics) and the primitives it
drew (a primitives-generated query: a pass's vertex work), work that travels across
hardware (``approx.cost``)."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING

import moderngl

from .invocations import InvocationQuery
from .late_timer import TIMER_SENTINEL, LateTimer

if TYPE_CHECKING:
    from .resources import FrameResources


def timer_queries_work(ctx: moderngl.Context) -> bool:
    """False on software rasterisers; else run one timed clear and check the answer
    is a plausible elapsed time (not the sentinel, not zero)."""
    from .context import is_software

    if is_software(ctx):
        return False
    try:
        query = ctx.query(time=True)
        tex = ctx.texture((256, 256), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[tex])
        with query:
            fbo.clear(0.5, 0.5, 0.5, 1.0)
        elapsed = query.elapsed
        fbo.release()
        tex.release()
    except Exception:
        return False
    return 0 < elapsed < TIMER_SENTINEL


class PassTimer:
    """The measured frame's per-pass seconds, fragments written and shaded, and
    primitives; ``method`` says how the seconds were measured. Passes never nest (one
    query of a kind at a time). Query results are read once, by :meth:`collect` after
    the frame's last pass, not per pass; with the wall clock (no timer queries) each pass
    still ends with ``ctx.finish()``. ``shaded`` holds a pass only where the driver counts
    invocations."""

    def __init__(self, ctx: moderngl.Context, use_queries: bool, pool: FrameResources | None = None):
        self.ctx = ctx
        self.pool = pool  # where its queries come from and go back to once read (else new ones)
        self.use_queries = use_queries
        self.method = "gl_timer_query" if use_queries else "finish_wall_clock"
        self.counts = True  # it counts each pass's work (fragments, primitives)
        self.seconds: dict[str, float] = {}
        self.fragments: dict[str, int] = {}
        self.primitives: dict[str, int] = {}
        self.shaded: dict[str, int] = {}
        self._pending: list[tuple] = []  # (pass name, its query or None, its invocation query or None)

    def add(self, name: str, fragments: int, primitives: int) -> None:
        """Count work of pass ``name`` measured elsewhere."""
        self.fragments[name] = self.fragments.get(name, 0) + int(fragments)
        self.primitives[name] = self.primitives.get(name, 0) + int(primitives)

    def count(self, name: str, queries: list[moderngl.Query]) -> None:
        """Count the work of pass ``name`` that its own (samples, primitives) queries
        measure (``measure(..., counted=False)``: GL queries of one kind cannot nest),
        read by :meth:`collect`."""
        self._pending += [(name, ("counted", q), None) for q in queries]

    @contextlib.contextmanager
    def measure(self, name: str, counted: bool = True) -> Iterator[None]:
        """Time the pass ``name`` and, when ``counted``, count its fragments (written and
        shaded) and primitives."""
        kinds = {"samples": counted, "primitives": counted, "time": self.use_queries}
        make = self.pool.query if self.pool is not None else self.ctx.query
        query = make(**kinds) if any(kinds.values()) else None
        invocations = InvocationQuery(self.ctx) if counted else None
        if invocations is not None:
            invocations.begin()
        if not self.use_queries:
            self.ctx.finish()
        t0 = time.perf_counter()
        with query if query is not None else contextlib.nullcontext():
            yield
        if not self.use_queries:
            self.ctx.finish()
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0
        if invocations is not None:
            invocations.stop()
        self._pending.append((name, (("timed" if self.use_queries else "") + ("counted" if counted else ""), query),
                              invocations))

    def collect(self) -> None:
        """Read every query of the frame (after its last pass: one wait, not one per pass)."""
        for name, (kind, query), invocations in self._pending:
            if "timed" in kind:
                elapsed = query.elapsed
                seconds = elapsed / 1e9 if elapsed != TIMER_SENTINEL else float("nan")
                self.seconds[name] = self.seconds.get(name, 0.0) + seconds
            if "counted" in kind:
                self.add(name, query.samples, query.primitives)
            if invocations is not None:
                shaded = invocations.read()
                invocations.release()
                if shaded is not None:
                    self.shaded[name] = self.shaded.get(name, 0) + shaded
        if self.pool is not None:
            self.pool.recycle([query for _, (_, query), _ in self._pending if query is not None])
        self._pending = []


class DisplayTimer:
    """A display frame's pass timer: ``late``'s timestamps (``approx.late_timer.LateTimer``,
    read frames later) where timer queries work, else nothing; it counts no work and never
    waits (``approx.renderer.Renderer.draw``)."""

    def __init__(self, late: LateTimer | None):
        self.late = late
        self.method = late.method if late is not None else "none"
        self.counts = False

    def measure(self, name: str, counted: bool = True) -> contextlib.AbstractContextManager:
        return self.late.measure(name) if self.late is not None else contextlib.nullcontext()

    def count(self, name: str, queries: list) -> None:
        """Nothing: a display frame makes no counting queries."""
