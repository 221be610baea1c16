"""`volcaustics doctor`: can this machine run the harness, and if not, the fix."""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
import sys
from dataclasses import dataclass, field


@dataclass
class Check:
    name: str
    ok: bool
    detail: str
    fix: str = ""


@dataclass
class DoctorReport:
    checks: list[Check] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(c.ok for c in self.checks)

    def add(self, name: str, ok: bool, detail: str, fix: str = "") -> None:
        self.checks.append(Check(name, ok, detail, fix))


def _gpu() -> str:
    smi = shutil.which("nvidia-smi")
    if not smi:
        return "none (no nvidia-smi)"
    try:
        out = subprocess.run([smi, "--query-gpu=name,memory.total", "--format=csv,noheader"],
                             capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired):
        return "none (nvidia-smi failed)"
    return out.stdout.strip().replace("\n", "; ") or "none (nvidia-smi lists no GPU)"


def _cpu() -> str:
    model = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{os.cpu_count()} cores{', ' + model if model else ''}"


def run_doctor() -> DoctorReport:
    """Probe GL, libLLVM and Mitsuba variants; every failing check carries its fix.
    Imports here: a broken install is what the doctor reports on, not a crash at import."""
    from volcaustics import reference  # chooses libLLVM before drjit is imported
    from volcaustics.approx.context import GL_REQUIRE, ContextError, gl_info, shared_context
    from volcaustics.reference.llvm import MIN_MAJOR, libllvm_major
    from volcaustics.reference.variant import probe

    report = DoctorReport()
    report.add("python", True, f"{platform.python_version()} ({sys.executable})")
    report.add("cpu", True, _cpu())
    report.add("gpu", True, _gpu())

    try:
        ctx = shared_context()
        info = gl_info(ctx)
        ok = info["version_code"] >= GL_REQUIRE
        report.add("opengl", ok, f"{info['renderer']} | {info['version']} | EGL",
                   "" if ok else f"OpenGL >= {GL_REQUIRE} needed (compute shaders): update Mesa or the GPU driver")
    except ContextError as exc:
        report.add("opengl", False, "no EGL context", str(exc))

    path, how = reference.LIBLLVM_PATH, reference.LIBLLVM_HOW
    major = libllvm_major(path) if path else None
    llvm_ok = path is not None and os.path.exists(path) and (major is None or major >= MIN_MAJOR)
    report.add("libllvm", llvm_ok, f"{path or 'none'} ({how})",
               "" if llvm_ok else (f"apt-get install libllvm19, then unset DRJIT_LIBLLVM_PATH or set it to "
                                   f"/usr/lib/x86_64-linux-gnu/libLLVM-19.so (Dr.Jit needs libLLVM >= {MIN_MAJOR})"))

    try:
        from importlib.metadata import version

        report.add("mitsuba", True, f"mitsuba {version('mitsuba')}, drjit {version('drjit')}")
    except Exception as exc:
        report.add("mitsuba", False, f"not installed ({exc})", "make setup (pip install -e '.[test]')")

    from volcaustics.reference.variant import PREFERRED

    rendering = []
    for variant in ("scalar_rgb", "llvm_ad_rgb", "cuda_ad_rgb"):
        ok, detail, seconds = probe(variant)
        if ok:
            rendering.append(variant)
        role = ("usable for the reference" if variant in PREFERRED else
                "not usable for the reference (its integrators need a JIT RGB variant)")
        report.add(f"variant {variant}", True,
                   f"{'renders' if ok else 'unavailable'}, {role}: {detail} ({seconds:.1f} s)")
    usable = [v for v in PREFERRED if v in rendering]
    report.add("reference variant", bool(usable), usable[0] if usable else "none",
               "" if usable else "llvm_ad_rgb must render: apt-get install libllvm19 and unset DRJIT_LIBLLVM_PATH "
                                 "(volcaustics then finds libLLVM-19 by itself)")
    _variant_override(report, rendering)
    return report


def _variant_override(report: DoctorReport, rendering: list) -> None:
    """VOLCAUSTICS_MI_VARIANT, when set, as every rendering command reads it."""
    from volcaustics.reference.mi_setup import VARIANT_ENV, variant_override
    from volcaustics.reference.variant import VariantError

    try:
        variant = variant_override()
    except VariantError as exc:
        report.add(VARIANT_ENV, False, repr(os.environ[VARIANT_ENV]), str(exc))
        return
    if variant is None:
        return
    ok = variant in rendering
    report.add(VARIANT_ENV, ok, f"{variant} ({'renders' if ok else 'does not render here'})",
               "" if ok else f"unset {VARIANT_ENV} to let volcaustics choose a variant that renders")


def format_report(report: DoctorReport) -> str:
    width = max(len(c.name) for c in report.checks)
    lines = []
    for c in report.checks:
        mark = "ok  " if c.ok else "FAIL"
        lines.append(f"{mark} {c.name:<{width}}  {c.detail}")
        if not c.ok and c.fix:
            lines.append(f"     {'':<{width}}  fix: {c.fix}")
    lines.append("the harness can run here" if report.ok else "the harness cannot run here: apply the fixes above")
    return "\n".join(lines)
