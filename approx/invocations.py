"""Fragment shader invocations of a pass (GL_ARB_pipeline_statistics_query, core in GL
4.6): the fragments a pass *shades*, discarded ones included, beside the samples-passed
count of those it writes (``approx.timing``). A beam's quad is shaded over every pixel
near the beam's line, and most of them are discarded where the beam lies behind a
surface or beyond its kernel, so its time follows the shaded count, not the written one
(docs/decisions.md "Frame cost").

moderngl's queries do not include pipeline statistics, so the query's GL entry points are
taken from the EGL context's own table (``approx.gl_entry``); where the extension or
an entry point is missing the count is None and the cost model falls back to written
fragments.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Any

import moderngl

from .gl_entry import gl_function

FRAGMENT_SHADER_INVOCATIONS = 0x82F4  # GL_FRAGMENT_SHADER_INVOCATIONS_ARB
QUERY_RESULT = 0x8866                  # GL_QUERY_RESULT
EXTENSION = "GL_ARB_pipeline_statistics_query"


@dataclass(frozen=True)
class QueryEntry:
    """The GL entry points of a query (from the current EGL context's table)."""

    gen: Any
    delete: Any
    begin: Any
    end: Any
    result: Any


def query_entry() -> QueryEntry | None:
    """The query entry points, or None where libEGL or one of them is missing."""
    uint, ids = ctypes.c_uint, ctypes.POINTER(ctypes.c_uint)
    found = [gl_function("glGenQueries", None, ctypes.c_int, ids),
             gl_function("glDeleteQueries", None, ctypes.c_int, ids),
             gl_function("glBeginQuery", None, uint, uint),
             gl_function("glEndQuery", None, uint),
             gl_function("glGetQueryObjectui64v", None, uint, uint, ctypes.POINTER(ctypes.c_uint64))]
    return QueryEntry(*found) if all(fn is not None for fn in found) else None


class InvocationQuery:
    """Counts the fragment shader invocations between :meth:`begin` and :meth:`end` on
    ``ctx`` (the current context); ``count`` None where the driver cannot say."""

    def __init__(self, ctx: moderngl.Context):
        self.entry = query_entry() if EXTENSION in ctx.extensions else None
        self.id = ctypes.c_uint(0)
        if self.entry is not None:
            self.entry.gen(1, ctypes.byref(self.id))

    def begin(self) -> None:
        if self.entry is not None:
            self.entry.begin(FRAGMENT_SHADER_INVOCATIONS, self.id.value)

    def end(self) -> int | None:
        """End the query; the invocations counted (waits for the pass), or None."""
        self.stop()
        return self.read()

    def stop(self) -> None:
        """End the query without reading it (:meth:`read` after the frame)."""
        if self.entry is not None:
            self.entry.end(FRAGMENT_SHADER_INVOCATIONS)

    def read(self) -> int | None:
        """The invocations counted between :meth:`begin` and :meth:`stop` (waits for
        the pass), or None."""
        if self.entry is None:
            return None
        value = ctypes.c_uint64(0)
        self.entry.result(self.id.value, QUERY_RESULT, ctypes.byref(value))
        return int(value.value)

    def release(self) -> None:
        if self.entry is not None and self.id.value:
            self.entry.delete(1, ctypes.byref(self.id))
            self.id = ctypes.c_uint(0)
