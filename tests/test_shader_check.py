"""The shader check (scripts/check_shaders.py, run by make lint over every variant): the
Khronos reference compiler accepts the renderer's programs and flags a broken one."""

from __future__ import annotations

import os
import shutil

import pytest

from tests.shared import load_script

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
pytestmark = pytest.mark.skipif(shutil.which("glslangValidator") is None,
                                reason="glslangValidator missing (Debian glslang-tools; make setup installs it)")


def test_the_default_programs_compile_and_every_stage_file_is_checked():
    """The quick preset's and the best preset's programs (make lint compiles all ~7,000
    variants); no stage file is left out of the checked programs."""
    from volcaustics.approx.glsl import load_source
    from volcaustics.approx.params import PRESETS
    from volcaustics.approx.trace import PhotonTracer

    checker = load_script("check_shaders")
    items = [(f"{name} {preset}", shader.rsplit(".", 2)[-2], load_source(shader, d))
             for preset in ("quick", "best") for name, (shader, d) in PhotonTracer.programs(PRESETS[preset]).items()]
    assert checker.compile_all(items) == []
    assert checker.unchecked_stage_files() == []


def test_a_broken_shader_is_flagged_with_its_label():
    """Negative controls: an undeclared name, and the trace's ballot at GLSL 4.30 (which the
    reference compiler refuses: the reason the shaders are 4.50), each named; a good
    source beside them passes."""
    from volcaustics.approx.glsl import load_source
    from volcaustics.approx.params import PRESETS
    from volcaustics.approx.trace import PhotonTracer

    trace = load_source("trace/trace.comp.glsl", PhotonTracer.defines(PRESETS["quick"]))
    good = "#version 450 core\nlayout(local_size_x = 8) in;\nvoid main() {}\n"
    items = [("good", "comp", good), ("undeclared", "comp", good.replace("{}", "{ x = 1; }")),
             ("trace at 430", "comp", trace.replace("#version 450 core", "#version 430 core", 1))]
    problems = load_script("check_shaders").compile_all(items)
    assert len(problems) == 2, problems
    assert problems[0].startswith("undeclared: ") and "'x'" in problems[0]
    assert problems[1].startswith("trace at 430: ") and "ballotARB" in problems[1]
