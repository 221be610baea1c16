"""The GL-call helper (tests/approx/gl_calls.py) on small moderngl scripts traced by
apitrace: a display frame of draws and uploads has no blocking call, and each way of
making the CPU wait (moderngl's ``texture.read()``, ``buffer.read()``, ``fbo.read()``,
``ctx.finish()``, a time query's ``elapsed``) is caught inside its frame (negative
controls); LateTimer's frames stay free of them and make no queries after the first.
apitrace missing fails these tests with the command that installs it."""

from __future__ import annotations

import json
import textwrap

import pytest

from volcaustics.approx.debug_groups import DISPLAY_FRAME

from .gl_calls import GLCall, blocking_calls, frames, parse_dump, trace_script

# What both scripts start with: a context, a program and a triangle to draw
SETUP = textwrap.dedent('''
    import json
    import sys

    import moderngl
    import numpy as np

    from volcaustics.approx.debug_groups import DISPLAY_FRAME, debug_group

    ctx = moderngl.create_standalone_context(backend="egl")
    prog = ctx.program(
        vertex_shader="#version 330\\nin vec2 p;\\nvoid main() { gl_Position = vec4(p, 0.0, 1.0); }",
        fragment_shader="#version 330\\nout vec4 c;\\nvoid main() { c = vec4(1.0); }")
    vbo = ctx.buffer(np.array([-1, -1, 3, -1, -1, 3], "f4"))
    vao = ctx.vertex_array(prog, vbo, "p")
''')

# One display frame per argument, each doing the draws and uploads plus that argument's read.
FRAME_SCRIPT = SETUP + textwrap.dedent('''
    tex = ctx.texture((16, 16), 4)
    fbo = ctx.framebuffer([tex])
    query = ctx.query(time=True)
    READS = {"none": lambda: None, "texture.read": tex.read, "buffer.read": vbo.read, "fbo.read": fbo.read,
             "ctx.finish": ctx.finish, "query.elapsed": lambda: query.elapsed}
    for read in sys.argv[1:]:
        with debug_group(DISPLAY_FRAME):
            fbo.use()
            fbo.clear(0.0, 0.0, 0.0, 1.0)
            vbo.write(np.array([-1, -1, 3, -1, -1, 3], "f4"))
            with query:
                vao.render()
            READS[read]()
''')

# Frames timed by LateTimer around draws and uploads; what it collected goes to timer.json.
TIMER_SCRIPT = SETUP + textwrap.dedent('''
    from volcaustics.approx.late_timer import LateTimer

    fbo = ctx.framebuffer([ctx.texture((64, 64), 4)])
    timer = LateTimer(ctx, frames_in_flight=4)
    for frame in range(int(sys.argv[1])):
        if frame == int(sys.argv[1]) - 1:
            ctx.finish()  # between frames, so that the last frame collects the ones before, however slow
        with debug_group(DISPLAY_FRAME):
            timer.begin_frame()
            fbo.use()
            with timer.measure("draw"):
                vao.render()
            with timer.measure("upload"):
                vbo.write(np.array([-1, -1, 3, -1, -1, 3], "f4"))
            with timer.measure("draw"):
                vao.render()
            timer.end_frame()
    with open("timer.json", "w") as fh:
        json.dump({"collected": timer.collected, "dropped": timer.dropped, "supported": timer.supported}, fh)
    timer.release()
''')

EXPECTED = {"texture.read": "glGetTexImage", "buffer.read": "glMapBufferRange", "fbo.read": "glReadPixels",
            "ctx.finish": "glFinish", "query.elapsed": "glGetQueryObjectuiv"}


def names(calls: list[GLCall]) -> list[str]:
    return [call.name for call in calls]


@pytest.fixture(scope="module")
def traced_frames(tmp_path_factory):
    """The display frames of FRAME_SCRIPT run once with a clean frame first, then one
    frame per read, then a clean one again (one apitrace run for every control)."""
    folder = tmp_path_factory.mktemp("gl_calls")
    script = folder / "frames.py"
    script.write_text(FRAME_SCRIPT, encoding="utf-8")
    reads = ["none", *EXPECTED, "none"]
    return reads, frames(trace_script(script, reads, folder), DISPLAY_FRAME)


def test_a_frame_of_draws_and_uploads_has_no_blocking_call(traced_frames):
    reads, found = traced_frames
    assert len(found) == len(reads)
    for frame in (found[0], found[-1]):
        assert {"glDrawArraysInstanced", "glBufferSubData", "glClear"} <= set(names(frame)), names(frame)
        assert blocking_calls(frame) == []


@pytest.mark.parametrize("read", list(EXPECTED))
def test_each_read_of_the_gpu_is_a_blocking_call_of_its_frame(traced_frames, read):
    """Negative controls: moderngl's reads as apitrace dumps them, each caught."""
    reads, found = traced_frames
    blocking = blocking_calls(found[reads.index(read)])
    assert EXPECTED[read] in names(blocking), (read, blocking)
    if read == "buffer.read":
        assert blocking[0].arg("access") == "GL_MAP_READ_BIT"
    if read == "query.elapsed":
        assert blocking[0].arg("pname") == "GL_QUERY_RESULT"


def test_the_late_timer_never_blocks_and_makes_its_queries_once(tmp_path):
    """Ten frames of LateTimer: no blocking call in any, glGenQueries in the first frame
    only, every result read with GL_QUERY_RESULT_NO_WAIT after GL_QUERY_RESULT_AVAILABLE,
    and frames collected (late, never waited for; a glFinish before the last frame, outside
    the frames, makes sure some are ready to collect)."""
    script = tmp_path / "timer.py"
    script.write_text(TIMER_SCRIPT, encoding="utf-8")
    found = frames(trace_script(script, ["10"], tmp_path), DISPLAY_FRAME)
    assert len(found) == 10
    assert all(blocking_calls(frame) == [] for frame in found), [blocking_calls(frame) for frame in found]
    assert "glGenQueries" in names(found[0])
    assert [i for i, frame in enumerate(found) if "glGenQueries" in names(frame)] == [0]
    assert all(names(frame).count("glQueryCounter") == 6 for frame in found)
    reads = [call for frame in found for call in frame if call.name.startswith("glGetQueryObject")]
    assert {call.arg("pname") for call in reads} == {"GL_QUERY_RESULT_AVAILABLE", "GL_QUERY_RESULT_NO_WAIT"}
    result = json.loads((tmp_path / "timer.json").read_text(encoding="utf-8"))
    assert result["collected"], result
    numbers = [number for number, _ in result["collected"]]
    assert numbers[-1] == 8 and numbers == sorted(numbers) and len(numbers) + result["dropped"] == 9, result
    assert all(set(times) == {"draw", "upload"} for _, times in result["collected"])


# --- the helper on dumps written out ------------------------------------------------------

DUMP = '''// process.name = "/usr/bin/python3"
5 eglMakeCurrent(dpy = 0x1, draw = NULL, read = NULL, ctx = 0x2) = EGL_TRUE
10 glPushDebugGroup(source = GL_DEBUG_SOURCE_APPLICATION, id = 0, length = 3, message = "one")
11 glPushDebugGroup(source = GL_DEBUG_SOURCE_APPLICATION, id = 0, length = 5, message = "inner")
12 glDrawArrays(mode = GL_TRIANGLES, first = 0, count = 3)
13 glPopDebugGroup()
14 glBindBuffer(target = GL_PIXEL_PACK_BUFFER, buffer = 2)
15 glReadPixels(x = 0, y = 0, width = 4, height = 4, format = GL_RGBA, type = GL_FLOAT, pixels = NULL)
16 glBindBuffer(target = GL_PIXEL_PACK_BUFFER, buffer = 0)
17 glPopDebugGroup()
18 glPushDebugGroup(source = GL_DEBUG_SOURCE_APPLICATION, id = 0, length = 5, message = "other")
19 glFinish()
20 glPopDebugGroup()
21 glPushDebugGroup(source = GL_DEBUG_SOURCE_APPLICATION, id = 0, length = 3, message = "one")
22 glMapBufferRange(target = GL_ARRAY_BUFFER, offset = 0, length = 16, access = GL_MAP_WRITE_BIT) = 0x7f00
23 memcpy(dest = 0x7f00, src = blob(16), n = 16) // fake
24 glClientWaitSync(sync = 0x9, flags = GL_SYNC_FLUSH_COMMANDS_BIT, timeout = 0) = GL_TIMEOUT_EXPIRED
25 glWaitSync(sync = 0x9, flags = 0, timeout = 18446744073709551615)
26 glGetQueryObjectui64v(id = 3, pname = GL_QUERY_RESULT_NO_WAIT, params = &7)
27 glShaderSource(shader = 2, count = 1, string = &"a \\"(, b", length = NULL)
28 glPopDebugGroup()
'''


def test_frames_split_two_groups_and_keep_a_nested_one():
    calls = parse_dump(DUMP)
    assert calls[0].name == "eglMakeCurrent" and calls[0].result == "EGL_TRUE"
    assert calls[-2].arg("string") == '&"a \\"(, b"' and calls[-2].arg("length") == "NULL"
    one = frames(calls, "one")
    assert [[call.index for call in frame] for frame in one] == [[11, 12, 13, 14, 15, 16], list(range(22, 28))]
    assert [[call.index for call in frame] for frame in frames(calls, "inner")] == [[12]]
    with pytest.raises(ValueError, match="never popped"):
        frames(calls[:-1], "one")


def test_reads_into_buffers_polls_and_gpu_waits_are_not_blocking():
    """A read into a bound pack buffer, a write map, a zero-timeout poll, glWaitSync and
    GL_QUERY_RESULT_NO_WAIT do not stall the CPU; glFinish does."""
    calls = parse_dump(DUMP)
    assert [call.index for call in blocking_calls(calls)] == [19]
    unbound = [call for call in calls if call.name != "glBindBuffer"]
    assert [call.index for call in blocking_calls(unbound)] == [15, 19]
    waiting = parse_dump("30 glClientWaitSync(sync = 0x9, flags = 0, timeout = 1000) = GL_CONDITION_SATISFIED\n"
                         "31 glMapBuffer(target = GL_ARRAY_BUFFER, access = GL_READ_WRITE) = 0x1\n"
                         "32 glGetQueryObjectivARB(id = 1, pname = GL_QUERY_RESULT, params = &1)\n"
                         "33 glGetQueryBufferObjectui64v(id = 1, buffer = 2, pname = GL_QUERY_RESULT, offset = 0)\n")
    assert [call.index for call in blocking_calls(waiting)] == [30, 31, 32]
