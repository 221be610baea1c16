"""The one GLSL loader: shaders by name from ``approx/shaders/<pass>/``.

A shader file has no ``#version`` line; the loader writes ``#version 450 core``,
then one ``#define NAME VALUE`` per entry of :data:`SHARED_DEFINES` and of
``defines``, then the file with every ``#include "common/x.glsl"`` line replaced
by that file (paths relative to the shaders folder, each file included once).

:data:`SHARED_DEFINES` are the codes GLSL shares with Python, whose one source is
``scenes.formats`` (and ``scenes.rng``): every shader gets them. A shader (or the common file it
includes) states their defaults under ``#ifndef NAME`` so that it compiles on its
own; the loader's lines come first, so its values win.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from typing import cast

import moderngl

from volcaustics.scenes.formats import FLAG_BITS, SHAPE_KINDS, STATUS_CODES
from volcaustics.scenes.rng import FRESNEL_DIM, GOLDEN, MAX_TENTATIVE, ROTATION_PHOTON, TRACKING_DIM

SHADER_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "shaders")
GLSL_VERSION = "#version 450 core"
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)

#: Status codes and shape kinds as int, flag bits and the stratified numbers' constants
#: (``scenes.rng``) as uint (GLSL ``1u``: they are or-ed and added into uints).
SHARED_DEFINES = {**STATUS_CODES, **{name: f"{bit}u" for name, bit in FLAG_BITS.items()}, **SHAPE_KINDS,
                  "GOLDEN": f"{GOLDEN}u", "ROTATION_PHOTON": f"{ROTATION_PHOTON}u", "FRESNEL_DIM": f"{FRESNEL_DIM}u",
                  "TRACKING_DIM": f"{TRACKING_DIM}u", "MAX_TENTATIVE": f"{MAX_TENTATIVE}u"}


def _expand(text: str, seen: set[str]) -> str:
    def replace(match):
        rel = match.group(1)
        if rel in seen:
            return f"// {rel} already included"
        seen.add(rel)
        with open(os.path.join(SHADER_DIR, rel), encoding="utf-8") as fh:
            return f"// begin {rel}\n{_expand(fh.read(), seen)}\n// end {rel}"

    return _INCLUDE.sub(replace, text)


def build_source(text: str, defines: dict | None = None) -> str:
    """Full GLSL source from shader ``text`` (no #version line), :data:`SHARED_DEFINES`
    and ``defines`` (which cannot redefine a shared code)."""
    defines = defines or {}
    clash = sorted(SHARED_DEFINES.keys() & defines.keys())
    if clash:
        raise ValueError(f"defines {clash} are shared codes (scenes.formats) and cannot be redefined")
    lines = [GLSL_VERSION]
    for name, value in {**SHARED_DEFINES, **defines}.items():
        if isinstance(value, bool):
            value = int(value)
        lines.append(f"#define {name} {value}")
    return "\n".join(lines) + "\n" + _expand(text, set())


def load_source(name: str, defines: dict | None = None) -> str:
    """GLSL source of ``approx/shaders/<name>`` (e.g. ``"preview/preview.frag.glsl"``)."""
    with open(os.path.join(SHADER_DIR, name), encoding="utf-8") as fh:
        return build_source(fh.read(), defines)


def compute_shader(ctx: moderngl.Context, name: str, defines: dict | None = None) -> moderngl.ComputeShader:
    return ctx.compute_shader(load_source(name, defines))


def program(ctx: moderngl.Context, vertex: str, fragment: str, defines: dict | None = None) -> moderngl.Program:
    return ctx.program(vertex_shader=load_source(vertex, defines), fragment_shader=load_source(fragment, defines))


def uniform(prog: moderngl.Program | moderngl.ComputeShader, name: str) -> moderngl.Uniform:
    """``prog``'s uniform ``name``, typed as one (moderngl types a program's members as
    a union of uniform, block, attribute and varying); KeyError when it has none."""
    return cast(moderngl.Uniform, prog[name])


def set_uniforms(prog: moderngl.Program | moderngl.ComputeShader, **values: object) -> None:
    """Set the uniforms that the compiled program still has (unused ones are
    optimised away by the GLSL compiler, depending on defines)."""
    for name, value in values.items():
        if name in prog:
            uniform(prog, name).value = value


def attribute_layout(prog: moderngl.Program, parts: Iterable[tuple[str, str | None]],
                     per_instance: bool = False) -> tuple[str, list[str]]:
    """moderngl buffer format and attribute names for ``parts`` = [(format, name or None)],
    turning attributes the program does not use into padding."""
    fmt, names = [], []
    for f, name in parts:
        if name is not None and name in prog:
            fmt.append(f)
            names.append(name)
        else:
            count, kind = (int(f[:-1]) if f[:-1] else 1), f[-1]
            fmt.append(f"{count * (4 if kind == 'f' else 1)}x")
    return " ".join(fmt) + ("/i" if per_instance else ""), names
