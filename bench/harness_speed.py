"""The harness's own speed, as a new user meets it.

    .venv/bin/python bench/harness_speed.py [--scenes LIST] [--tests] [--keep DIR]

On a fresh cache (a new ``$VOLCAUSTICS_CACHE``), one after another:

1. ``volcaustics report`` cold: references, then every point measured;
2. the same report warm (everything from the stores);
3. ``volcaustics gate --render-references`` after a change to one shader (a ``#define``
   appended to ``approx/shaders/trace/trace.comp.glsl`` for the run and taken out
   after it, so every point's code version differs and every point is measured
   again);
4. ``volcaustics measure sphere1`` at the report's settings (6 seeds, its reference
   cached by step 1);
5. a 16-point sweep (sphere1: layers 1, 2, 4, 8 × iterations 4, 8, 16, 30, one seed);
6. with ``--tests``: the whole suite (``scripts/run_tests.sh``) and its 25 slowest tests.

Prints one table: each command's wall seconds and, for the cold report, where they
went (the references' render seconds from their manifests, each experiment stage
summed over the points' summaries) with their shares. The figures of the speed work
are in docs/history.md "Harness speed".
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLI = os.path.join(ROOT, ".venv", "bin", "volcaustics")
SHADER = os.path.join(ROOT, "approx", "shaders", "trace", "trace.comp.glsl")


def timed(command: list, env: dict, log: str) -> float:
    """Wall seconds of ``command`` (its output appended to ``log``); exits on failure."""
    t0 = time.perf_counter()
    with open(log, "a") as fh:
        fh.write(f"$ {' '.join(command)}\n")
        fh.flush()
        done = subprocess.run(command, env=env, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT)
    seconds = time.perf_counter() - t0
    if done.returncode not in (0, 1):  # 1: a gate verdict, still a finished run
        sys.exit(f"{' '.join(command)} exited {done.returncode}: see {log}")
    return seconds


def cold_report_stages(cache: str) -> dict:
    """Seconds by stage of what the cold report computed: each reference's render
    seconds, each experiment stage summed over the stored points."""
    stages = {"references": 0.0}
    for path in glob.glob(os.path.join(cache, "reference", "*.json")):
        with open(path) as fh:
            stages["references"] += float(json.load(fh).get("wall_seconds", 0.0))
    for path in glob.glob(os.path.join(cache, "report-results", "points", "*", "summary.json")):
        with open(path) as fh:
            for stage, seconds in json.load(fh)["experiment_seconds"].items():
                if stage not in ("reference", "total"):
                    stages[stage] = stages.get(stage, 0.0) + seconds
    return stages


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", help="the report's and the gate's scenes (default: every built-in)")
    parser.add_argument("--tests", action="store_true", help="also run the whole suite (minutes)")
    parser.add_argument("--keep", help="use this folder for the cache and outputs (default: a new temporary one)")
    args = parser.parse_args(argv)
    work = args.keep or tempfile.mkdtemp(prefix="harness-speed-")
    os.makedirs(work, exist_ok=True)
    cache, log = os.path.join(work, "cache"), os.path.join(work, "log.txt")
    env = {**os.environ, "VOLCAUSTICS_CACHE": cache}
    scenes = ["--scenes", args.scenes] if args.scenes else []
    rows = []
    report = [CLI, "report", "--out", os.path.join(work, "report"), "--quiet", *scenes]
    rows.append(("report, cold", timed(report, env, log)))
    stages = cold_report_stages(cache)
    rows.append(("report, warm", timed(report, env, log)))
    with open(SHADER) as fh:
        shader = fh.read()
    try:
        with open(SHADER, "a") as fh:
            fh.write("\n#define VC_HARNESS_SPEED 1\n")  # code, not a comment: comments keep result keys
        gate = [CLI, "gate", "--render-references", "--quiet", "--out", os.path.join(work, "gate"), *scenes]
        rows.append(("gate after a shader change", timed(gate, env, log)))
    finally:
        with open(SHADER, "w") as fh:
            fh.write(shader)
    rows.append(("measure sphere1 (6 seeds)", timed([CLI, "measure", "sphere1", "--seeds", "6", "--quiet", "-o",
                                                     os.path.join(work, "measure")], env, log)))
    sweep = [CLI, "sweep", "--scenes", "sphere1", "--vary", "layers=1,2,4,8", "--vary", "iterations=4,8,16,30",
             "--quiet", "-o", os.path.join(work, "sweep")]
    rows.append(("sweep, 16 points (sphere1)", timed(sweep, env, log)))
    if args.tests:
        tests_log = os.path.join(work, "tests.txt")
        rows.append(("make test (whole suite)", timed(["bash", "scripts/run_tests.sh"], os.environ, tests_log)))
    print(f"{'what':<34} {'seconds':>9} {'share':>7}")
    for name, seconds in rows:
        print(f"{name:<34} {seconds:>9.1f}")
        if name == "report, cold":
            for stage, s in stages.items():
                print(f"  {stage:<32} {s:>9.1f} {s / seconds:>7.0%}")
    if args.tests:
        with open(tests_log) as fh:
            lines = fh.read().splitlines()
        start = next((i for i, line in enumerate(lines) if "slowest" in line), None)
        print("\n".join(lines[start:start + 27]) if start is not None else "(no durations in the suite's output)")
    print(f"(cache, outputs and the commands' output: {work})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
