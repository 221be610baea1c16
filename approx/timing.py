"""Per-pass GPU times: timer queries where the driver supports them, else
``ctx.finish()`` and a wall clock (llvmpipe answers 4294967295 to timer queries,
a sentinel that is never reported)."""

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
    """Accumulates seconds per pass name; ``method`` says how they were measured."""

    def __init__(self, ctx: moderngl.Context, use_queries: bool):
        self.ctx = ctx
        self.use_queries = use_queries
        self.method = "gl_timer_query" if use_queries else "finish_wall_clock"
        self.seconds: dict[str, float] = {}

    @contextlib.contextmanager
    def measure(self, name: str):
        if self.use_queries:
            query = self.ctx.query(time=True)
            with query:
                yield
            elapsed = query.elapsed
            seconds = elapsed / 1e9 if elapsed != TIMER_SENTINEL else float("nan")
        else:
            self.ctx.finish()
            t0 = time.perf_counter()
            yield
            self.ctx.finish()
            seconds = time.perf_counter() - t0
        self.seconds[name] = self.seconds.get(name, 0.0) + seconds
