"""The GL context and the one shader loader."""

from __future__ import annotations

import pytest

from volcaustics.approx.context import GL_REQUIRE, gl_info
from volcaustics.approx.glsl import GLSL_VERSION, SHADER_DIR, build_source, load_source


def test_context_is_gl43_or_newer(ctx):
    info = gl_info(ctx)
    assert info["version_code"] >= GL_REQUIRE
    assert info["renderer"]


def test_defines_and_includes_expand_once():
    src = build_source('#include "common/rng.glsl"\n#include "common/rng.glsl"\nvoid f() {}\n',
                       {"LAYERS": 4, "STOCHASTIC": True})
    lines = src.splitlines()
    assert lines[0] == GLSL_VERSION == "#version 450 core"
    assert "#define LAYERS 4" in lines and "#define STOCHASTIC 1" in lines
    assert src.count("uint pcg_hash(uint v)") == 1
    assert "#include" not in src


def test_loaded_preview_shaders_compile(ctx):
    prog = ctx.program(vertex_shader=load_source("camera/gbuffer.vert.glsl"),
                       fragment_shader=load_source("preview/preview.frag.glsl"))
    assert "view_proj" in prog
    prog.release()


def test_missing_include_is_an_error():
    with pytest.raises(FileNotFoundError):
        build_source('#include "common/absent.glsl"\n')
    assert SHADER_DIR.endswith("shaders")


def test_framebuffers_can_be_released_and_recreated(ctx):
    """Releasing the last-bound framebuffer must not break the next one (see approx.context.bound)."""
    from volcaustics.approx.context import bound

    for _ in range(3):
        color = ctx.texture((4, 4), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[color])
        assert ctx.error == "GL_NO_ERROR"
        with bound(ctx, fbo):
            fbo.clear(1.0, 0.5, 0.25, 1.0)
            pixel = fbo.read(components=4, dtype="f4")
        fbo.release()
        color.release()
        assert pixel[:16] == bytes(memoryview(__import__("numpy").array([1.0, 0.5, 0.25, 1.0], "f4")))
