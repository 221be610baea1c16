"""The display frame feeds the GPU and never waits on it, as apitrace sees its GL calls:
a steady-state ``Renderer.draw`` (the paper's points, best, beams with Fresnel splits)
makes no call that blocks the CPU (glFinish, a read, a read map, a query result) and makes,
deletes or reallocates no GL object. Two negative controls show the check can fail: a
texture read slipped into the splat pass, and the measured frame (``Renderer.render``)
in the display frame's debug group. apitrace missing fails these tests with the command
that installs it (tests/approx/gl_calls.py)."""

from __future__ import annotations

import json
import re
import textwrap

import pytest

from volcaustics.approx.debug_groups import DISPLAY_FRAME

from .display_configs import CONFIGS, SCENE
from .gl_calls import GLCall, blocking_calls, frames, trace_script

WARMUP, STEADY = 2, 3  # display frames per run: the first compile programs and make the pool's objects

# Runs the plan (a JSON file: scene, then [control, parameters] per run) as WARMUP + STEADY
# frames each. control "draw": Renderer.draw; "splat_read": draw with the splat pass's target
# read back after each splat; "render": Renderer.render in the display frame's debug group.
SCRIPT = textwrap.dedent('''
    import json
    import sys

    from volcaustics.approx.debug_groups import DISPLAY_FRAME, debug_group
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Renderer
    from volcaustics.approx.splat import Splatter
    from volcaustics.scenes import resolve_scene

    plan = json.load(open(sys.argv[1]))
    control = {"now": "draw"}
    splat = Splatter.splat

    def splat_then_read(self, splats, commands, view, medium, splat_radius, scene_distance, target, *args, **kw):
        splat(self, splats, commands, view, medium, splat_radius, scene_distance, target, *args, **kw)
        if control["now"] == "splat_read":
            target.read()  # the fault: the CPU waits for the splats

    Splatter.splat = splat_then_read
    scene = resolve_scene(plan["scene"])
    renderer = Renderer(scene)
    for name, params in plan["runs"]:
        control["now"] = name
        p = ApproxParams(**params)
        for _ in range(plan["frames"]):
            if name == "render":
                with debug_group(DISPLAY_FRAME):
                    renderer.render(scene, p, keep_records=False)
            else:
                renderer.draw(scene, p)
    renderer.release()
''')

RUNS = [*(("draw", name) for name in CONFIGS), ("splat_read", "paper"), ("render", "paper")]
# glGen*/glCreate* make a GL object (buffers, textures, framebuffers, renderbuffers, vertex
# arrays, queries, samplers, shaders, programs), glDelete* drops one; glBufferData and
# glTex(ture)Image/Storage give one new storage. glGenerateMipmap makes nothing.
MAKES = re.compile(r"gl(Gen(?!erate)|Create|Delete)\w+|glBufferData|glNamedBufferData|glBufferStorage"
                   r"|glNamedBufferStorage|glTex(ture)?(Image|Storage)\w*")


def made(calls: list[GLCall]) -> list[str]:
    """The names of the calls that make, drop or reallocate a GL object."""
    return [call.name for call in calls if MAKES.fullmatch(call.name)]


@pytest.fixture(scope="module")
def traced_runs(tmp_path_factory) -> dict:
    """(control, configuration) → its display frames, WARMUP + STEADY: every run of
    :data:`RUNS` in one traced process (one renderer, one context), in that order."""
    folder = tmp_path_factory.mktemp("display_frame_calls")
    script, plan = folder / "frames.py", folder / "plan.json"
    script.write_text(SCRIPT, encoding="utf-8")
    plan.write_text(json.dumps({"scene": SCENE, "frames": WARMUP + STEADY,
                                "runs": [[control, CONFIGS[name].to_dict()] for control, name in RUNS]}),
                    encoding="utf-8")
    found = frames(trace_script(script, [str(plan)], folder), DISPLAY_FRAME)
    assert len(found) == len(RUNS) * (WARMUP + STEADY)
    per_run = WARMUP + STEADY
    return {run: found[i * per_run:(i + 1) * per_run] for i, run in enumerate(RUNS)}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_a_steady_display_frame_has_no_blocking_call_and_makes_nothing(traced_runs, name):
    """Each steady-state display frame of ``name`` issues its passes (draws and compute
    dispatches, indirect splat draws) with no call that makes the CPU wait for the GPU and
    no GL object made, deleted or given new storage: the GPU is fed, not waited on."""
    for frame in traced_runs[("draw", name)][WARMUP:]:
        names = {call.name for call in frame}
        assert {"glDispatchCompute", "glMultiDrawArraysIndirect"} <= names, sorted(names)
        assert blocking_calls(frame) == [], [(c.index, c.name, c.args[:120]) for c in blocking_calls(frame)]
        assert made(frame) == [], made(frame)


def test_a_read_in_the_splat_pass_is_caught(traced_runs):
    """Negative control: the splat target read back after each splat (moderngl's
    ``texture.read()``, glGetTexImage) shows as blocking calls in every steady frame, one
    per step at least."""
    steps = CONFIGS["paper"].steps
    for frame in traced_runs[("splat_read", "paper")][WARMUP:]:
        blocking = [call.name for call in blocking_calls(frame)]
        assert blocking.count("glGetTexImage") >= steps, blocking


def test_the_measured_frame_in_the_group_is_caught(traced_runs):
    """Negative control: the measured frame (``Renderer.render``: a finish or query read
    per pass, then the images read) in the display frame's debug group shows blocking
    calls in every steady frame, so the check sees the renderer's own waits."""
    for frame in traced_runs[("render", "paper")][WARMUP:]:
        blocking = {call.name for call in blocking_calls(frame)}
        assert blocking & {"glFinish", "glGetQueryObjectuiv", "glGetQueryObjectui64v", "glGetQueryObjecti64v"}, blocking
        assert {"glGetTexImage", "glReadPixels"} & blocking, blocking


def test_the_first_display_frame_makes_its_objects(traced_runs):
    """Negative control of the object check: the renderer's first display frame compiles
    its programs and makes the pool's buffers, images and framebuffers, and the same check
    sees each kind."""
    first = set(made(traced_runs[("draw", "paper")][0]))
    assert {"glCreateProgram", "glGenBuffers", "glGenTextures", "glGenFramebuffers"} <= first, sorted(first)
