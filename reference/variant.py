"""Which Mitsuba variants actually render here, and which one the reference uses.

A variant counts only if a tiny scene renders to finite, non-zero pixels. Each
probe runs in a child process: a wrong libLLVM aborts the process inside the
JIT, which must not take the caller down. Run as ``python -m reference.variant
VARIANT`` to probe one variant.
"""

from __future__ import annotations

import functools
import json
import sys
import time

from volcaustics.infra.errors import InputError

PREFERRED = ("cuda_ad_rgb", "llvm_ad_rgb")


class VariantError(InputError):
    """The environment asks for a Mitsuba variant or libLLVM the reference cannot use;
    the message names the variable, its value and the fix."""


def _render_tiny(variant: str) -> float:
    import mitsuba as mi

    mi.set_variant(variant)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, -3], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 8, "height": 8, "rfilter": {"type": "box"}}},
        "emitter": {"type": "constant"},
        "shape": {"type": "sphere", "bsdf": {"type": "diffuse"}},
    })
    import numpy as np

    image = np.asarray(mi.render(scene, spp=4))
    return float(image.mean())


def probe(variant: str, timeout: float = 120.0) -> tuple[bool, str, float]:
    """(renders, detail, seconds) for ``variant``, tried in a child process."""
    import subprocess  # here, not at the top: a cache hit reads PREFERRED only

    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-m", "volcaustics.reference.variant", variant],
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return False, f"timed out after {timeout:.0f} s", time.perf_counter() - t0
    seconds = time.perf_counter() - t0
    lines = proc.stdout.strip().splitlines()
    if proc.returncode == 0 and lines:
        result = json.loads(lines[-1])
        if result.get("ok"):
            return True, f"mean {result['mean']:.3g}", seconds
        return False, result.get("error", "failed"), seconds
    tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
    return False, f"crashed (exit {proc.returncode}): {tail[:160]}", seconds


@functools.lru_cache(maxsize=1)
def reference_variant() -> str:
    """``cuda_ad_rgb`` where it renders, else ``llvm_ad_rgb`` (probed once per process)."""
    for variant in PREFERRED:
        if probe(variant)[0]:
            return variant

    raise VariantError("no Mitsuba variant renders here (cuda_ad_rgb and llvm_ad_rgb both failed a tiny render); "
                       "run `volcaustics doctor` for the fix")


def _main(variant: str) -> int:
    from volcaustics.reference.llvm import ensure_libllvm

    ensure_libllvm()
    try:
        mean = _render_tiny(variant)
    except Exception as exc:  # reported to the parent, which prints the reason
        reason = str(exc).splitlines()[0][:160] if str(exc) else ""
        print(json.dumps({"ok": False, "error": f"{type(exc).__name__}: {reason}"}))
        return 0
    ok = mean == mean and 0.0 < mean < float("inf")
    print(json.dumps({"ok": ok, "mean": mean, "error": "" if ok else f"rendered mean {mean}"}))
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1]))
