"""Seconds of one experiment (``volcaustics measure``) per scene, stage by stage.

    .venv/bin/python bench/measure.py [SCENE ...] [--seeds 1,2] [--repeat 2]

At the quick preset (256², photon_res 256, light_res 256) with the report's
reference, which must be cached (``make report`` caches it; otherwise the first
run renders it, up to minutes per scene). All experiments run in one process, as a
sweep worker does: the first experiment of a scene pays the one-time costs (Python
imports, shader compilation, the metric floors of the reference, then cached on
disk) and is reported apart; the figure of merit is the median of the later runs.
The issue asks for ≤ 5 s per scene on the 2-core machine.
"""

from __future__ import annotations

import argparse
import sys
import time


def main(argv=None) -> int:
    from volcaustics.approx.params import QUICK
    from volcaustics.experiment.pipeline import run_experiment
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.catalogue import BUILTIN_NAMES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=list(BUILTIN_NAMES))
    parser.add_argument("--seeds", default="1,2", help="comma-separated seed counts (default 1,2)")
    parser.add_argument("--repeat", type=int, default=2, help="timed runs after the first (default 2)")
    args = parser.parse_args(argv)
    stages = ("reference", "approx", "segments", "photons", "exact_images", "metrics")
    print(f"{'scene':12} {'seeds':>5} {'first s':>8} {'median s':>9}  " + " ".join(f"{s:>12}" for s in stages))
    for name in args.scenes:
        scene = resolve_scene(name)
        for seeds in (int(x) for x in args.seeds.split(",")):
            t0 = time.perf_counter()
            run_experiment(scene, QUICK, seeds=seeds)
            first = time.perf_counter() - t0
            runs = [run_experiment(scene, QUICK, seeds=seeds).summary["experiment_seconds"]
                    for _ in range(args.repeat)]
            runs.sort(key=lambda c: c["total"])
            mid = runs[len(runs) // 2]
            print(f"{name:12} {seeds:>5} {first:>8.2f} {mid['total']:>9.2f}  "
                  + " ".join(f"{mid[s]:>12.2f}" for s in stages), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
