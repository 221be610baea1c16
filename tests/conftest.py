"""Shared fixtures: the one GL context (checked for GL errors around every test)
and scene-file helpers. Importing ``reference`` first picks libLLVM for Dr.Jit."""

from __future__ import annotations

import os
import textwrap

import pytest

# One exact replay per emission texel in the decomposition's E_∞ images (the report's 16
# cost the suite 10 minutes); the tests of the sub-photons set their own.
os.environ.setdefault("VOLCAUSTICS_EXACT_SUBPHOTONS", "1")

import volcaustics.reference  # noqa: F401  (chooses DRJIT_LIBLLVM_PATH before anything imports drjit)


@pytest.fixture(scope="session")
def gl_context():
    from volcaustics.approx.context import shared_context

    return shared_context()


@pytest.fixture
def ctx(gl_context):
    """The session's GL context; fails a test that leaves a GL error behind."""
    assert gl_context.error == "GL_NO_ERROR"
    yield gl_context
    assert gl_context.error == "GL_NO_ERROR"


BASE_SCENE = """
name = "base"
description = "small valid scene for loader tests"

[camera]
position = [0.0, 1.0, 4.0]
target = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 64
height = 48

[light]
position = [0.0, 3.0, 0.0]
direction = [0.0, -1.0, 0.0]
intensity = [5.0, 5.0, 5.0]
cutoff_angle = 25.0
beam_width = 20.0

[medium]
sigma_s = 0.2
sigma_a = [0.01, 0.01, 0.01]
phase = "isotropic"

[[specular]]
name = "ball"
mesh = { generator = "sphere", radius = 0.5, subdivisions = 3 }
transform = { translate = [0.0, 1.0, 0.0] }
ior = 1.5
absorption = [0.0, 0.0, 0.0]

[[diffuse]]
name = "floor"
mesh = { generator = "quad", size_x = 4.0, size_z = 4.0 }
albedo = 0.5
"""


@pytest.fixture
def write_scene(tmp_path):
    """Write TOML text (default: a small valid scene) to a file; returns its path."""

    def write(text: str = BASE_SCENE, name: str = "scene.toml") -> str:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text))
        return str(path)

    return write
