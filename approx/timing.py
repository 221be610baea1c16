"""Per-pass GPU times: timer queries where the driver supports them, else
``ctx.finish()`` and a wall clock (llvmpipe answers 4294967295 to timer queries,
a sentinel that is never reported); and per pass the fragments it wrote (a GL
samples-passed query: fragments that reach the framebuffer, so a fragment shader's
discards are not counted), work that travels across hardware (``approx.cost``)."""

from __future__ import annotations

import contextlib
import time

import moderngl

TIMER_SENTINEL = 4294967295


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
    """Accumulates seconds and fragments written per pass name; ``method`` says how the
    seconds were measured. Passes never nest (one query of a kind at a time)."""

    def __init__(self, ctx: moderngl.Context, use_queries: bool):
        self.ctx = ctx
        self.use_queries = use_queries
        self.method = "gl_timer_query" if use_queries else "finish_wall_clock"
        self.seconds: dict[str, float] = {}
        self.fragments: dict[str, int] = {}

    @contextlib.contextmanager
    def measure(self, name: str):
        query = self.ctx.query(samples=True, time=self.use_queries)
        if self.use_queries:
            with query:
                yield
            elapsed = query.elapsed
            seconds = elapsed / 1e9 if elapsed != TIMER_SENTINEL else float("nan")
        else:
            self.ctx.finish()
            t0 = time.perf_counter()
            with query:
                yield
            self.ctx.finish()
            seconds = time.perf_counter() - t0
        self.seconds[name] = self.seconds.get(name, 0.0) + seconds
        self.fragments[name] = self.fragments.get(name, 0) + int(query.samples)
