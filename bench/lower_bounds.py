"""The declared dependency ranges, tested at their lower bounds.

    .venv/bin/python bench/lower_bounds.py [--venv .venv-lower] [--keep] [PYTEST ARGS ...]
    make lower-bounds

Reads ``[project] dependencies`` and the ``test`` extra from pyproject.toml, pins
every requirement with a lower bound (``>=X``) to exactly ``==X``, installs the
project into a separate virtual environment under those pins (pip's
``--constraint``, so an unsatisfiable set fails here, not on a user's machine),
runs ``pip check``, and then the default test suite in that environment.

Exit 0 when the install, ``pip check`` and the tests pass; otherwise the failing
step's exit code. This is a bench rather than part of ``make test``: a cold
install downloads ~1 GB of wheels and the suite then runs a second time.

The interpreter is the one running this script (``requires-python`` starts at
3.10; this machine has 3.11), so the Python lower bound is not covered here.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import tomllib
from packaging.markers import default_environment
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parent.parent


def lower_bound_pins(pyproject: Path, extras=("test",)) -> list[str]:
    """``name==X`` for every requirement (dependencies and ``extras``) whose
    specifier has ``>=X`` and whose marker holds on this interpreter."""
    project = tomllib.loads(pyproject.read_text())["project"]
    lines = list(project["dependencies"])
    for extra in extras:
        lines += project["optional-dependencies"][extra]
    env = default_environment()
    pins = []
    for line in lines:
        req = Requirement(line)
        if req.marker is not None and not req.marker.evaluate(env):
            continue
        lows = [s.version for s in req.specifier if s.operator == ">="]
        if not lows:
            raise SystemExit(f"lower_bounds: {pyproject}: {line!r} has no '>=' lower bound; declare one")
        pins.append(f"{req.name}=={lows[0]}")
    return pins


def _step(title: str, cmd: list[str], env=None) -> int:
    print(f"\n[lower-bounds] {title}: {' '.join(cmd)}", flush=True)
    t0 = time.perf_counter()
    rc = subprocess.call(cmd, cwd=ROOT, env=env)
    print(f"[lower-bounds] {title}: exit {rc} after {time.perf_counter() - t0:.0f} s", flush=True)
    return rc


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--venv", default=".venv-lower", help="environment to (re)create (default .venv-lower)")
    ap.add_argument("--keep", action="store_true", help="reuse the environment if it exists")
    args, pytest_args = ap.parse_known_args(argv)

    pins = lower_bound_pins(ROOT / "pyproject.toml")
    print("[lower-bounds] pins:\n  " + "\n  ".join(pins))
    venv = ROOT / args.venv
    python = venv / "bin" / "python"
    if venv.exists() and not args.keep:
        shutil.rmtree(venv)
    if not python.exists():
        rc = _step("create", [sys.executable, "-m", "venv", str(venv)])
        if rc:
            return rc
    with tempfile.NamedTemporaryFile("w", suffix=".txt", prefix="lower-bounds-", delete=False) as f:
        f.write("\n".join(pins) + "\n")
        constraints = f.name
    try:
        rc = _step("install", [str(python), "-m", "pip", "install", "-q", "--constraint", constraints,
                               "-e", ".[test]"])
    finally:
        os.unlink(constraints)
    if rc:
        return rc
    rc = _step("pip check", [str(python), "-m", "pip", "check"])
    if rc:
        return rc
    subprocess.call([str(python), "-m", "pip", "list", "--format=freeze"], cwd=ROOT)
    return _step("tests", [str(python), "-m", "pytest", "-q", "-p", "no:cacheprovider", *pytest_args])


if __name__ == "__main__":
    sys.exit(main())
