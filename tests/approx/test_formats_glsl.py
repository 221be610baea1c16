"""The GLSL side of the shared formats (scenes.formats): every std430 struct of
common/photon.glsl has its numpy dtype's layout, the shaders receive the very
code values Python uses, and their stated defaults agree with them."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

from volcaustics.approx import glsl
from volcaustics.approx.glsl import SHADER_DIR, SHARED_DEFINES, build_source
from volcaustics.scenes.bounds import box_exit
from volcaustics.scenes.formats import (
    BEAM_DTYPE,
    FLAG_BITS,
    PHOTON_DTYPE,
    RAW_RECORD_DTYPE,
    SHAPE_KINDS,
    SPLAT_DTYPE,
    STATUS_CODES,
)
from volcaustics.scenes.rng import FRESNEL_DIM, GOLDEN, MAX_TENTATIVE, ROTATION_PHOTON, TRACKING_DIM

STRUCTS = [("Photon", PHOTON_DTYPE), ("Record", RAW_RECORD_DTYPE), ("Splat", SPLAT_DTYPE), ("Beam", BEAM_DTYPE)]
# numpy kind → (GLSL scalar type, vector prefix, literal suffix)
GLSL_TYPES = {"f": ("float", "vec", ".0"), "u": ("uint", "uvec", "u"), "i": ("int", "ivec", "")}
COUNT = 3  # structs written: element i lands at i × stride, so a wrong stride shows


def known_values(dtype: np.dtype, count: int) -> np.ndarray:
    """``count`` rows of ``dtype`` whose every scalar is distinct: 1000·row + 10·field + component + 1."""
    out = np.zeros(count, dtype)
    for i in range(count):
        for k, name in enumerate(dtype.names):
            shape = dtype[name].shape
            n = shape[0] if shape else 1
            values = [1000 * i + 10 * k + c + 1 for c in range(n)]
            out[i][name] = values if shape else values[0]
    return out


def writer_shader(struct: str, dtype: np.dtype, rows: np.ndarray) -> str:
    """Test fixture shader (generated): writes ``rows`` field by field into a buffer of ``struct``."""
    lines = []
    for i, row in enumerate(rows):
        for name in dtype.names:
            field = dtype[name]
            scalar, vector, suffix = GLSL_TYPES[field.base.kind]
            values = [int(v) for v in np.atleast_1d(row[name])]
            glsl_type = f"{vector}{len(values)}" if field.shape else scalar
            literal = ", ".join(f"{v}{suffix}" for v in values)
            lines.append(f"    items[{i}].{name} = {glsl_type}({literal});")
    body = "\n".join(lines)
    return f"""
#include "common/photon.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 0) writeonly buffer Items {{ {struct} items[]; }};
layout(std430, binding = 1) writeonly buffer Length {{ uint item_count; }};
void main() {{
{body}
    item_count = uint(items.length());
}}
"""


@pytest.mark.parametrize("struct, dtype", STRUCTS, ids=[s for s, _ in STRUCTS])
def test_std430_struct_matches_its_dtype(ctx, struct, dtype):
    assert dtype.itemsize % 16 == 0  # std430 rounds a struct with vec4 members up to 16 bytes
    expected = known_values(dtype, COUNT)
    shader = ctx.compute_shader(build_source(writer_shader(struct, dtype, expected)))
    items = ctx.buffer(b"\xff" * (COUNT * dtype.itemsize))  # NaN everywhere: unwritten bytes show
    length = ctx.buffer(reserve=4)
    items.bind_to_storage_buffer(0)
    length.bind_to_storage_buffer(1)
    shader.run(group_x=1)
    got = np.frombuffer(items.read(), dtype)
    item_count = int(np.frombuffer(length.read(), np.uint32)[0])
    for r in (items, length, shader):
        r.release()
    # items.length() = buffer size / GLSL stride: the GLSL struct is itemsize bytes
    assert item_count == COUNT, f"GLSL {struct} is not {dtype.itemsize} bytes: {item_count} fit in {COUNT} dtype rows"
    for name in dtype.names:
        assert np.array_equal(got[name], expected[name]), f"{struct}.{name}: GLSL wrote {got[name]}"
    assert got.tobytes() == expected.tobytes()  # and no byte of the layout is left unwritten


def code_reader_shader(names) -> str:
    """Test fixture shader (generated): writes each shared code, as the shaders see it, to values[]."""
    body = "\n".join(f"    values[{k}] = int({name});" for k, name in enumerate(names))
    return f"""
#include "common/photon.glsl"
#include "common/kinds.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 0) writeonly buffer Values {{ int values[]; }};
void main() {{
{body}
}}
"""


def read_codes(ctx, names) -> dict:
    shader = ctx.compute_shader(build_source(code_reader_shader(names)))
    out = ctx.buffer(reserve=4 * len(names))
    out.bind_to_storage_buffer(0)
    shader.run(group_x=1)
    values = np.frombuffer(out.read(), np.int32)
    out.release()
    shader.release()
    return dict(zip(names, values.tolist()))


PYTHON_CODES = {**STATUS_CODES, **FLAG_BITS, **SHAPE_KINDS}
# the stratified numbers' constants (uint beyond int32: test_rng_glsl.py checks them in use)
RNG_CONSTANTS = {"GOLDEN": GOLDEN, "ROTATION_PHOTON": ROTATION_PHOTON, "FRESNEL_DIM": FRESNEL_DIM,
                 "TRACKING_DIM": TRACKING_DIM, "MAX_TENTATIVE": MAX_TENTATIVE}


def test_shared_defines_are_the_python_codes():
    expected = {**PYTHON_CODES, **RNG_CONSTANTS}
    assert set(SHARED_DEFINES) == set(expected)
    for name, value in SHARED_DEFINES.items():
        assert str(value).rstrip("u") == str(expected[name]), name


def test_shaders_receive_the_python_codes(ctx):
    assert read_codes(ctx, list(PYTHON_CODES)) == PYTHON_CODES


def test_shader_defaults_are_the_python_codes(ctx, monkeypatch):
    """Without the loader's defines the common files compile on their own, and the
    defaults they state are the Python values."""
    monkeypatch.setattr(glsl, "SHARED_DEFINES", {})
    assert build_source("") == glsl.GLSL_VERSION + "\n"  # nothing injected
    assert read_codes(ctx, list(PYTHON_CODES)) == PYTHON_CODES


def shader_files():
    for folder, _, files in os.walk(SHADER_DIR):
        for f in sorted(files):
            if f.endswith(".glsl"):
                yield os.path.relpath(os.path.join(folder, f), SHADER_DIR)


def test_every_shader_states_defaults_of_the_codes_it_uses(monkeypatch):
    """A shader reads and compiles on its own: each shared code it uses (itself or
    through its includes) has an ``#ifndef`` default."""
    monkeypatch.setattr(glsl, "SHARED_DEFINES", {})
    used_somewhere = set()
    for rel in shader_files():
        with open(os.path.join(SHADER_DIR, rel), encoding="utf-8") as fh:
            source = build_source(fh.read())
        source = re.sub(r"//[^\n]*", "", re.sub(r"/\*.*?\*/", "", source, flags=re.DOTALL))  # code, not comments
        used = {name for name in PYTHON_CODES if re.search(rf"\b{name}\b", source)}
        used_somewhere |= used
        missing = sorted(name for name in used if f"#ifndef {name}" not in source)
        assert not missing, f"{rel} uses {missing} without stating a default"
    assert {"STATUS_COLLIDED", "FLAG_TIR", "KIND_DIFFUSE", "KIND_NONE"} <= used_somewhere


def test_shared_codes_cannot_be_redefined():
    with pytest.raises(ValueError, match="STATUS_LOST"):
        build_source("void main() {}\n", {"STATUS_LOST": 7})


BOX_EXIT_CHECK = """
#include "common/box.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Rays { vec4 rays[]; };  // (origin, 0), (direction, 0) pairs
layout(std430, binding = 1) writeonly buffer Exits { float exits[]; };
uniform vec3 box_lo;
uniform vec3 box_hi;
uniform uint count;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    exits[i] = box_exit(rays[2u * i].xyz, rays[2u * i + 1u].xyz, box_lo, box_hi);
}
"""


def test_glsl_box_exit_matches_numpy_twin(ctx):
    rng = np.random.default_rng(11)
    n = 4096
    lo, hi = np.array([-2.0, 0.0, -1.5]), np.array([3.0, 4.0, 2.5])
    origins = lo + rng.random((n, 3)) * (hi - lo)
    directions = rng.normal(size=(n, 3))
    directions[:6] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]  # zero components
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins, directions = origins.astype(np.float32), directions.astype(np.float32)
    rays = np.zeros((n, 2, 4), np.float32)
    rays[:, 0, :3], rays[:, 1, :3] = origins, directions
    shader = ctx.compute_shader(build_source(BOX_EXIT_CHECK))
    src, out = ctx.buffer(rays.tobytes()), ctx.buffer(reserve=4 * n)
    src.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    shader["box_lo"].value, shader["box_hi"].value, shader["count"].value = tuple(lo), tuple(hi), n
    shader.run(group_x=(n + 63) // 64)
    got = np.frombuffer(out.read(), np.float32)
    for r in (src, out, shader):
        r.release()
    want = box_exit(origins.astype(np.float64), directions.astype(np.float64), lo, hi)
    assert np.all(np.isfinite(got))
    assert np.allclose(got, want, rtol=1e-5, atol=1e-6)
    # the exit point lies on the box surface
    exit_points = origins + directions * want[:, None]
    on_face = np.isclose(exit_points, lo, atol=1e-5) | np.isclose(exit_points, hi, atol=1e-5)
    assert np.all(on_face.any(axis=1))


def test_the_media_storage_bindings_are_the_shaders_defaults():
    """The storage-buffer bindings a heterogeneous medium's programs read (the density grid,
    its majorants, beams' eye knots) are bound by ``approx.medium_volumes`` at the binding
    points their GLSL files state; a binding one off fails here, not as a silent read of
    another buffer."""
    from volcaustics.approx import medium_volumes

    stated = {}
    for name in ("common/density.glsl", "splat/eye_knots.glsl"):
        with open(os.path.join(SHADER_DIR, name), encoding="utf-8") as fh:
            stated.update(re.findall(r"^#define (\w+_BINDING) (\d+)$", fh.read(), re.MULTILINE))
    python = {name: getattr(medium_volumes, name) for name in ("DENSITY_BINDING", "MAJORANT_BINDING",
                                                                "EYE_KNOTS_BINDING")}
    assert {name: int(value) for name, value in stated.items()} == python
