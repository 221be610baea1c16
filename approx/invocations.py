"""Fragment shader invocations of a pass (GL_ARB_pipeline_statistics_query, core in GL
4.6): the fragments a pass *shades*, discarded ones included, beside the samples-passed
count of those it writes (``approx.timing``). A beam's quad is shaded over every pixel
near the beam's line, and most of them are discarded where the beam lies behind a
surface or beyond its kernel, so its time follows the shaded count, not the written one
(docs/decisions.md "Frame cost").

moderngl's queries do not include pipeline statistics, so the four GL entry points are
taken from the EGL context's own table (``eglGetProcAddress``); where the extension or
an entry point is missing the count is None and the cost model falls back to written
fragments.
"""

from __future__ import annotations

import ctypes
import ctypes.util
from functools import lru_cache

import moderngl

FRAGMENT_SHADER_INVOCATIONS = 0x82F4  # GL_FRAGMENT_SHADER_INVOCATIONS_ARB
QUERY_RESULT = 0x8866                  # GL_QUERY_RESULT
EXTENSION = "GL_ARB_pipeline_statistics_query"


class _Entry:
    """The GL entry points of a query (from the current EGL context's table)."""

    def __init__(self, lookup):
        def fn(name, *args):
            address = lookup(name.encode())
            if not address:
                raise OSError(f"{name}: no entry point")
            return ctypes.CFUNCTYPE(None, *args)(address)

        uint = ctypes.c_uint
        self.gen = fn("glGenQueries", ctypes.c_int, ctypes.POINTER(uint))
        self.delete = fn("glDeleteQueries", ctypes.c_int, ctypes.POINTER(uint))
        self.begin = fn("glBeginQuery", uint, uint)
        self.end = fn("glEndQuery", uint)
        self.result = fn("glGetQueryObjectui64v", uint, uint, ctypes.POINTER(ctypes.c_uint64))


@lru_cache(maxsize=1)
def _entry() -> _Entry | None:
    name = ctypes.util.find_library("EGL") or "libEGL.so.1"
    try:
        egl = ctypes.CDLL(name)
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        return _Entry(egl.eglGetProcAddress)
    except (OSError, AttributeError):
        return None


class InvocationQuery:
    """Counts the fragment shader invocations between :meth:`begin` and :meth:`end` on
    ``ctx`` (the current context); ``count`` None where the driver cannot say."""

    def __init__(self, ctx: moderngl.Context):
        self.entry = _entry() if EXTENSION in ctx.extensions else None
        self.id = ctypes.c_uint(0)
        if self.entry is not None:
            self.entry.gen(1, ctypes.byref(self.id))

    def begin(self) -> None:
        if self.entry is not None:
            self.entry.begin(FRAGMENT_SHADER_INVOCATIONS, self.id.value)

    def end(self) -> int | None:
        """End the query; the invocations counted (waits for the pass), or None."""
        if self.entry is None:
            return None
        self.entry.end(FRAGMENT_SHADER_INVOCATIONS)
        value = ctypes.c_uint64(0)
        self.entry.result(self.id.value, QUERY_RESULT, ctypes.byref(value))
        return int(value.value)

    def release(self) -> None:
        if self.entry is not None and self.id.value:
            self.entry.delete(1, ctypes.byref(self.id))
            self.id = ctypes.c_uint(0)
