"""GL entry points that moderngl does not wrap (debug groups, timestamp queries, pipeline
statistics), taken from the current EGL context's table through ``eglGetProcAddress``.

The lookup goes through the process's libEGL (``dlopen`` by soname), so under apitrace
it reaches the traced library and every call made through these pointers is traced.
Mesa answers any ``gl*`` name with a dispatch stub, so a non-None function does not
prove the driver has it: check :func:`current_gl_version` (or the extension list) too.
"""

from __future__ import annotations

import ctypes
import ctypes.util
from collections.abc import Callable
from functools import lru_cache
from typing import Any

MAJOR_VERSION = 0x821B  # GL_MAJOR_VERSION
MINOR_VERSION = 0x821C  # GL_MINOR_VERSION


@lru_cache(maxsize=1)
def egl_library() -> ctypes.CDLL | None:
    """The process's libEGL with ``eglGetProcAddress`` and ``eglGetCurrentContext``
    typed, or None where there is none."""
    try:
        egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        egl.eglGetCurrentContext.restype = ctypes.c_void_p
        egl.eglGetCurrentContext.argtypes = []
    except (OSError, AttributeError):
        return None
    return egl


@lru_cache(maxsize=None)
def gl_function(name: str, restype: Any, *argtypes: Any) -> Callable[..., Any] | None:
    """The GL function ``name`` as a ctypes callable (``restype`` None for void, then the
    C argument types), or None where libEGL or the entry point is missing. Cached: one
    lookup per signature and process (EGL 1.5 pointers are context-independent)."""
    egl = egl_library()
    address = egl.eglGetProcAddress(name.encode()) if egl is not None else None
    if not address:
        return None
    return ctypes.CFUNCTYPE(restype, *argtypes)(address)


_VERSIONS: dict[int, tuple[int, int]] = {}


def current_gl_version() -> tuple[int, int] | None:
    """(major, minor) of the EGL context current on this thread, or None when none is
    current; asked of the driver once per context."""
    egl = egl_library()
    handle = egl.eglGetCurrentContext() if egl is not None else None
    if not handle:
        return None
    if handle not in _VERSIONS:
        get = gl_function("glGetIntegerv", None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
        if get is None:
            return None
        major, minor = ctypes.c_int(0), ctypes.c_int(0)
        get(MAJOR_VERSION, ctypes.byref(major))
        get(MINOR_VERSION, ctypes.byref(minor))
        _VERSIONS[handle] = (major.value, minor.value)
    return _VERSIONS[handle]
