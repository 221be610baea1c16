"""The one place that makes the OpenGL context.

Headless EGL standalone context: Mesa llvmpipe on a machine without a GPU, the
GPU driver where there is one; the same code runs unchanged on both. GL 4.5 is
required (compute shaders and SSBOs came with 4.3; the shaders are GLSL 4.50, the
version from which the Khronos reference compiler takes the trace's subgroup ballot:
docs/decisions.md "Shaders under the reference compiler").
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import moderngl

GL_REQUIRE = 450


class ContextError(RuntimeError):
    """No usable OpenGL context; the message carries the fix."""


def create_context() -> moderngl.Context:
    """A new standalone EGL OpenGL >= 4.5 core context (prefer :func:`shared_context`)."""
    try:
        return moderngl.create_standalone_context(backend="egl", require=GL_REQUIRE)  # type: ignore[arg-type]
    except Exception as exc:
        raise ContextError(
            f"cannot create a headless OpenGL {GL_REQUIRE // 100}.{GL_REQUIRE % 100 // 10} context through EGL "
            f"({type(exc).__name__}: {exc}). Fix: apt-get install libegl1 libgl1-mesa-dri "
            "(Mesa llvmpipe) or install the GPU driver's EGL library") from None


_SHARED: moderngl.Context | None = None


def shared_context() -> moderngl.Context:
    """The process's one GL context, created on first use and kept.

    Standalone contexts are made current when created and never switched back, so
    a second context in the same process silently breaks the first; library code
    and tests all use this one.
    """
    global _SHARED
    if _SHARED is None:
        _SHARED = create_context()
    return _SHARED


_HOME: dict[int, moderngl.Framebuffer] = {}


@contextlib.contextmanager
def bound(ctx: moderngl.Context, fbo: moderngl.Framebuffer) -> Iterator[moderngl.Framebuffer]:
    """Render into ``fbo`` inside the block; afterwards bind what was bound before.

    Standalone contexts have no default framebuffer; without this, releasing the
    last-used framebuffer leaves a dangling binding and the next framebuffer
    creation raises GL_INVALID_OPERATION. When nothing was bound before, a 1×1
    'home' framebuffer kept per context is bound instead.
    """
    previous = ctx.fbo
    fbo.use()
    try:
        yield fbo
    finally:
        if previous is None:
            key = id(ctx)
            if key not in _HOME:
                _HOME[key] = ctx.framebuffer(color_attachments=[ctx.renderbuffer((1, 1))])
            previous = _HOME[key]
        previous.use()


def gl_info(ctx: moderngl.Context) -> dict:
    """Renderer, version and vendor strings of ``ctx``."""
    info = ctx.info
    return {"renderer": info["GL_RENDERER"], "version": info["GL_VERSION"], "vendor": info["GL_VENDOR"],
            "version_code": ctx.version_code}


def is_software(ctx: moderngl.Context) -> bool:
    """True on a CPU rasteriser (llvmpipe, softpipe, swrast), where timer queries are unsupported."""
    renderer = ctx.info["GL_RENDERER"].lower()
    return any(name in renderer for name in ("llvmpipe", "softpipe", "swrast"))
