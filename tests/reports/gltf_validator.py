"""The Khronos glTF-Validator from the tests: ``scripts/gltf_validate.mjs`` run by Node
on several files at once (one Node start, about 0.3 s, for all of them)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "scripts", "gltf_validate.mjs")
INSTALL = "bash scripts/setup.sh --browser"
NOT_INSTALLED = 3  # the script's exit code when the npm package is missing


class ValidatorUnavailable(RuntimeError):
    """Node or the npm package ``gltf-validator`` is missing: the message says which and
    the command that installs it."""


def validate_gltf(paths) -> tuple[str, dict]:
    """(validator version, {path: report}) for the ``.glb``/``.gltf`` files ``paths``:
    each report the validator's own dict (``issues``: ``numErrors``, ``numWarnings``,
    ``numInfos``, ``numHints``, ``messages``; ``info``). ValidatorUnavailable when it
    cannot run here; RuntimeError when a file could not be validated at all."""
    node = shutil.which("node")
    if node is None:
        raise ValidatorUnavailable(f"node is not on PATH: install Node.js (>= 18) and npm, then `{INSTALL}`")
    done = subprocess.run([node, SCRIPT, *map(str, paths)], capture_output=True, text=True, timeout=300)
    if done.returncode == NOT_INSTALLED:
        raise ValidatorUnavailable(f"the npm package gltf-validator is not installed: run `{INSTALL}` "
                                   f"(installs it into .tools/node_modules)")
    if done.returncode != 0:
        raise RuntimeError(f"gltf_validate.mjs exited {done.returncode}: {done.stderr.strip()[-2000:]}")
    out = json.loads(done.stdout)
    return out["validator"], out["reports"]
