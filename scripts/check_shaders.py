"""The shader check (``make lint`` and a test): every program the renderer can compile,
for every combination of the parameter table's string-valued #defines, each integer
one at the ends of its range, each renderer control and both phase functions, compiles
under the Khronos reference compiler (``glslangValidator``, Debian ``glslang-tools``).
The driver here (Mesa llvmpipe) accepts what it accepts; the same shaders are meant to
run unchanged on NVIDIA's compiler, which nothing here runs, so a second, strict
front end checks the language itself.

The programs and their defines come from the classes that compile them
(``PhotonTracer.programs``, ``Splatter.programs``, ``CameraPasses.programs``,
``LightMapRenderer.STAGES``, ``preview.PREVIEW_STAGES``): one source for both. Every
stage file under ``approx/shaders`` (``*.vert.glsl``, ``*.frag.glsl``, ``*.comp.glsl``)
must be in one of them, so a new shader cannot go unchecked.

Prints one line per failing source (its program and defines, then the compiler's
errors) and exits 1 when there is one; 2 when glslangValidator is missing.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import shutil
import subprocess
import sys
import tempfile

STAGE_SUFFIXES = {".vert.glsl": "vert", ".frag.glsl": "frag", ".comp.glsl": "comp"}
PHASES = (("isotropic", 0.0), ("hg", 0.6))
CHUNK = 400  # sources per compiler call (its start-up is most of a small shader's cost)


def _int_values(param) -> list:
    """An integer #define's values: the ends of its range and its default."""
    return sorted({param.low, param.high, param.default} - {None})


def trace_variants() -> list:
    """(label, params, controls) of every trace program setting checked: every
    combination of the string-valued #defines (with each control alone, and none), and
    each integer #define at its range's ends with the others at their defaults."""
    from volcaustics.approx.controls import CONTROLS, control_programs
    from volcaustics.approx.params import PARAMS, ApproxParams

    table = [p for p in PARAMS if p.glsl == "define" and p.program == "trace"]
    strings = [p for p in table if p.choices]
    on = {"CLIP_TO_OBJECTS": 1, "DIFFERENTIAL_UNPROPAGATED": 1, "EMISSION_SHIFT": 0.5, "GRID_IGNORED": 1,
          "MAJORANT_SCALE": 0.25, "EXACT_MARCH": 1}
    controls = [{}] + [{name: on[name]} for name in CONTROLS if "trace" in control_programs(name)]
    out = []
    for values in itertools.product(*(p.choices for p in strings)):
        params = ApproxParams(**dict(zip((p.name for p in strings), values)))
        out += [(f"{dict(zip((p.name for p in strings), values))} {c or ''}", params, c) for c in controls]
    for p in table:
        if p.kind is int:
            out += [(f"{p.name}={v}", dataclasses.replace(ApproxParams(), **{p.name: v}), {}) for v in _int_values(p)]
    return out


def programs() -> list:
    """(label, stage files, defines) of every program checked."""
    from volcaustics.approx.controls import CONTROLS, control_programs
    from volcaustics.approx.layers import LightMapRenderer
    from volcaustics.approx.params import PARAMS
    from volcaustics.approx.preview import PREVIEW_STAGES
    from volcaustics.approx.trace import PhotonTracer
    from volcaustics.scenes.density import Density
    from volcaustics.scenes.model import Medium, Phase

    out = [("light maps", LightMapRenderer.STAGES, {}), ("preview", PREVIEW_STAGES, {})]
    for label, params, controls in trace_variants():
        out += [(f"{name} {label}", (shader,), d)
                for name, (shader, d) in PhotonTracer.programs(params, controls).items()]
    # a heterogeneous medium (a density grid): its emission, trace and depth-volume programs
    grid = Medium(sigma_s=(0.1, 0.1, 0.1), density=Density(field="box"))
    for label, params, controls in trace_variants():
        if {"GRID_IGNORED", "MAJORANT_SCALE", "EXACT_MARCH"} & set(controls) or not controls:
            out += [(f"{name} {label} heterogeneous", (shader,), d)
                    for name, (shader, d) in PhotonTracer.programs(params, controls, grid).items()]
    out.append(("transmittance volume", ("medium/depth_volume.comp.glsl",), {}))
    out.append(("beams' eye knots", ("splat/eye_knots.comp.glsl",), {}))
    splat_controls = [{}] + [{name: 1} for name in CONTROLS if "splat" in control_programs(name)]
    fog = next(p for p in PARAMS if p.name == "fog_steps")
    for kind, g in PHASES:
        for medium in (Medium(sigma_s=(0.1, 0.1, 0.1), sigma_a=(0.0, 0.0, 0.0), phase=Phase(kind=kind, g=g)),
                       Medium(sigma_s=(0.1, 0.1, 0.1), phase=Phase(kind=kind, g=g), density=Density(field="box"))):
            out += _shading(medium, kind, splat_controls, fog)
    return out


def _shading(medium, kind: str, splat_controls: list, fog) -> list:
    """The splat and camera programs of ``medium`` (homogeneous or not) with phase ``kind``."""
    from volcaustics.approx.camera_pass import CameraPasses
    from volcaustics.approx.params import ApproxParams, defines
    from volcaustics.approx.splat import Splatter

    out = []
    where = " heterogeneous" if medium.is_heterogeneous else ""
    for mode, controls in itertools.product(("fixed", "adaptive", "density", "beams", "balanced beams"),
                                            splat_controls):
        if controls and mode not in ("density", "beams", "balanced beams") and not controls.keys() & {"EXACT_EYE"}:
            continue
        for name, (stages, d) in Splatter.programs(medium, adaptive=mode == "adaptive", density=mode == "density",
                                                    beams=mode.endswith("beams"), balanced=mode == "balanced beams",
                                                    controls=controls).items():
            out.append((f"{name} splat={mode} phase={kind}{where} {controls or ''}", stages, d))
    for steps in _int_values(fog):
        fog_defines = defines(ApproxParams(fog_steps=steps), "fog")
        for name, (stages, d) in CameraPasses.programs(medium, fog_defines).items():
            out.append((f"{name} fog_steps={steps} phase={kind}{where}", stages, d))
    return out


def sources(checked: list | None = None) -> list:
    """(label, stage, GLSL source) of every distinct stage source of ``checked`` (default
    :func:`programs`)."""
    from volcaustics.approx.glsl import load_source

    seen, out = set(), []
    for label, stages, d in programs() if checked is None else checked:
        for shader in stages:
            text = load_source(shader, d)
            if text not in seen:
                seen.add(text)
                out.append((f"{shader} ({label})", STAGE_SUFFIXES[_suffix(shader)], text))
    return out


def _suffix(name: str) -> str:
    return next(s for s in STAGE_SUFFIXES if name.endswith(s))


def unchecked_stage_files(checked: list | None = None) -> list:
    """Stage files under approx/shaders that no program of ``checked`` (default
    :func:`programs`) uses."""
    from volcaustics.approx.glsl import SHADER_DIR

    used = {shader for _, stages, _ in (programs() if checked is None else checked) for shader in stages}
    files = []
    for folder, _, names in os.walk(SHADER_DIR):
        files += [os.path.relpath(os.path.join(folder, n), SHADER_DIR).replace(os.sep, "/") for n in names
                  if any(n.endswith(s) for s in STAGE_SUFFIXES)]
    return sorted(set(files) - used)


def compile_all(items: list, compiler: str = "glslangValidator") -> list:
    """One problem line per source of ``items`` ((label, stage, text)) that does not
    compile: its label and the compiler's errors."""
    problems = []
    with tempfile.TemporaryDirectory(prefix="volcaustics-shaders-") as folder:
        paths = []
        for i, (_, stage, text) in enumerate(items):
            paths.append(os.path.join(folder, f"{i:05d}.{stage}"))
            with open(paths[-1], "w", encoding="utf-8") as fh:
                fh.write(text)
        for start in range(0, len(paths), CHUNK):
            chunk = paths[start:start + CHUNK]
            result = subprocess.run([compiler, *chunk], capture_output=True, text=True)
            if result.returncode == 0:
                continue
            errors = _errors_by_file(result.stdout + result.stderr, chunk)
            problems += [f"{items[start + i][0]}: " + "; ".join(errors[path][:6])
                         for i, path in enumerate(chunk) if errors.get(path)]
    return problems


def _errors_by_file(output: str, paths: list) -> dict:
    """The compiler's ERROR lines, by the file it printed before them."""
    out, current = {}, None
    for line in output.splitlines():
        if line.strip() in paths:
            current = line.strip()
        elif line.startswith("ERROR") and current is not None and "compilation errors" not in line:
            out.setdefault(current, []).append(line.strip())
    return out


def main() -> int:
    compiler = shutil.which("glslangValidator")
    if compiler is None:
        print("check_shaders: glslangValidator not found: install Debian's glslang-tools (make setup does)",
              file=sys.stderr)
        return 2
    checked = programs()
    items = sources(checked)
    problems = [f"{name}: a stage file no checked program uses (add it to its class's programs)"
                for name in unchecked_stage_files(checked)]
    problems += compile_all(items, compiler)
    for line in problems:
        print(line)
    print(f"check_shaders: {len(items)} distinct sources, {len(problems)} failing", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
