"""The standard sweep: every built-in × layers {1, 2, 4, 8} × iterations {4, 8, 16, 30}
at the quick preset, one seed, with the report's references (cached by ``make report``).

    .venv/bin/python bench/sweep.py [--out DIR] [--modes cold,warm,dask,single] [--scenes a,b]

Modes, each into its own fresh store under DIR (default runs/bench-sweep):
  cold    local worker processes, one per core (the default executor)
  warm    the same store again: everything is done, nothing is recomputed
  dask    a Dask LocalCluster of 2 process workers (``--dask local:2``), fresh store
  single  one local worker (``--workers 1``), fresh store
For each: wall seconds, points computed, the points' own seconds (median, in their
worker) and the overhead per point: wall × workers / points − the mean point time.
The issue asks: cold ≤ 15 minutes, warm ≤ 30 s on the 2-core machine; the Dask
speed-up over one worker and its overhead per point.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time

STANDARD_VARY = {"layers": (1, 2, 4, 8), "iterations": (4, 8, 16, 30)}


def main(argv=None) -> int:
    import numpy as np

    from volcaustics.reports.measuring.pools.executors import default_workers
    from volcaustics.reports.studies.sweep.sweep_run import run_sweep
    from volcaustics.reports.studies.sweep.sweep_spec import SweepSpec
    from volcaustics.scenes.catalogue import BUILTIN_NAMES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/bench-sweep")
    parser.add_argument("--modes", default="cold,warm,dask,single")
    parser.add_argument("--scenes", default=",".join(BUILTIN_NAMES))
    args = parser.parse_args(argv)
    spec = SweepSpec(scenes=tuple(args.scenes.split(",")), vary=tuple(STANDARD_VARY.items()))
    runs = {"cold": ("main", {"workers": default_workers()}), "warm": ("main", {"workers": default_workers()}),
            "dask": ("dask", {"dask": "local:2"}), "single": ("single", {"workers": 1})}
    print(f"{'mode':8} {'wall s':>8} {'points':>7} {'computed':>9} {'point s (median)':>17} {'overhead s/point':>17}")
    for mode in args.modes.split(","):
        folder, options = runs[mode]
        store = os.path.join(args.out, folder)
        if mode != "warm" and os.path.exists(store):
            shutil.rmtree(store)
        t0 = time.perf_counter()
        result = run_sweep(spec, store, progress=False, **options)
        wall = time.perf_counter() - t0
        seconds = np.asarray(result.point_seconds, float)
        slots = options.get("workers") or int(options.get("dask", "local:1").split(":")[1])
        overhead = wall * slots / max(result.computed, 1) - (seconds.mean() if len(seconds) else 0.0)
        print(f"{mode:8} {wall:8.1f} {result.total:7d} {result.computed:9d} "
              f"{(np.median(seconds) if len(seconds) else float('nan')):17.2f} "
              f"{(overhead if result.computed else float('nan')):17.2f}", flush=True)
        if result.failed:
            print(f"  {len(result.failed)} failed: {result.failed[0]['error']}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
