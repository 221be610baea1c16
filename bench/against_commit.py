"""The default frame's speed against an earlier commit, back to back on this machine.

    .venv/bin/python bench/against_commit.py [COMMIT] [SCENE] [--rounds 3] [--preset paper]
        [--set NAME=VALUE ...]

COMMIT (default 027d1f1, the code before the agreement fixes)
is checked out into a temporary git worktree. Each round runs one process per side,
alternating (old, new, old, new, ...), each rendering a warm-up frame (shader
compilation) and one timed frame of SCENE at the preset; the per-round frame and
trace times are printed with their medians and the ratio new/old. Both sides use
this checkout's virtual environment; the old side imports its own top-level folders
(before the ``volcaustics`` namespace, ``approx``/``scenes``), the new side
``volcaustics``. ``--set`` (new side only, e.g. search=hiz) times a variant against
the old default.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CHILD = """
import json, sys, time
namespace = sys.argv[1]
if namespace == "old":  # before the namespace and the PRESETS dict: PAPER / QUICK constants
    from approx import Renderer
    from approx import params as table
    from scenes import resolve_scene
else:
    from volcaustics.approx import Renderer
    from volcaustics.approx import params as table
    from volcaustics.scenes import resolve_scene
import dataclasses
params = getattr(table, sys.argv[3].upper())
changes = json.loads(sys.argv[4])
params = dataclasses.replace(params, **changes)
scene = resolve_scene(sys.argv[2])
renderer = Renderer(scene)
renderer.render(params=params, keep_records=False)
timings = renderer.render(params=params, keep_records=False).timings
print("RESULT " + json.dumps({"frame": timings["frame_wall"], "trace": timings["trace"]}))
"""


def _run(side: str, tree: str, scene: str, preset: str, changes: dict) -> dict:
    env = dict(os.environ)
    if side == "old":
        env["PYTHONPATH"] = tree
    out = subprocess.run([sys.executable, "-c", CHILD, side, scene, preset, json.dumps(changes)], cwd=tree,
                         env=env, capture_output=True, text=True, check=True).stdout
    return json.loads(next(line for line in out.splitlines() if line.startswith("RESULT "))[7:])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commit", nargs="?", default="027d1f1")
    parser.add_argument("scene", nargs="?", default="two_spheres")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    args = parser.parse_args(argv)
    from volcaustics.approx.params import param

    changes = {}
    for text in args.set:
        name, _, value = text.partition("=")
        changes[name] = param(name).parse(value)
    with tempfile.TemporaryDirectory() as tmp:
        old_tree = os.path.join(tmp, "old")
        subprocess.run(["git", "-C", ROOT, "worktree", "add", "--detach", "-f", old_tree, args.commit], check=True,
                       capture_output=True)
        try:
            results = {"old": [], "new": []}
            for k in range(args.rounds):
                for side in ("old", "new"):
                    r = _run(side, old_tree if side == "old" else ROOT, args.scene, args.preset,
                             {} if side == "old" else changes)
                    results[side].append(r)
                    print(f"round {k + 1} {side}: frame {r['frame']:.2f} s, trace {r['trace']:.2f} s", flush=True)
        finally:
            subprocess.run(["git", "-C", ROOT, "worktree", "remove", "--force", old_tree], capture_output=True)
    med = {side: {k: statistics.median(r[k] for r in rs) for k in ("frame", "trace")} for side, rs in results.items()}
    label = ", ".join(args.set) or "default"
    print(f"{args.scene}, preset {args.preset}; median of {args.rounds}: old ({args.commit}) frame "
          f"{med['old']['frame']:.2f} s, trace {med['old']['trace']:.2f} s; new ({label}) frame "
          f"{med['new']['frame']:.2f} s, trace {med['new']['trace']:.2f} s; new/old frame "
          f"{med['new']['frame'] / med['old']['frame']:.2f}×, trace {med['new']['trace'] / med['old']['trace']:.2f}×")
    return 0


if __name__ == "__main__":
    sys.exit(main())
