"""A cold sweep's scaling with workers: the same sweep with 1 and with 2 local worker
processes, each from an empty cache (its references render too, their batches on the
workers), the speed-up between them, the share of the time that stays serial (Amdahl:
1/S = (1 − p) + p/N), and the projection for N machines of a sweep of P points.

    .venv/bin/python bench/sweep_scaling.py [--sweeps mixed,references] [--cores shared,one]
                                            [--size 128] [--photon-res 256] [--points-projected 644]

Two sweeps: ``mixed`` (2 scenes × layers {1, 2, 4}, 2 seeds: 6 points on 2 references)
and ``references`` (2 scenes × 4 medium densities, 1 seed: 8 points, each on a
reference of its own: the reference-heavy sweep). Two ways to give the workers cores:
``shared`` (the machine's cores as a user's run has them: one worker renders on all of
them through Dr.Jit's and llvmpipe's threads) and ``one`` (a core per worker, the
whole run pinned to as many cores as it has workers: one worker stands for one
one-core machine, two for two).

Where the time goes is read from the runs themselves: the references' batch seconds
(their manifests, summed over the workers) and the points' own seconds (their
summaries). Figures: docs/decisions.md "Sweep scaling".
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

COMMON = """
[set]
width = {size}
height = {size}
photon_res = {photon_res}
light_res = 256
[reference]
photons = 4194304
spp = 16
batches = 8
target_noise = "none"
max_scatter = 1
[measurement]
exact_subphotons = 1
"""
SWEEPS = {
    "mixed": """
scenes = ["refocus", "sphere1"]
seeds = 2
[vary]
layers = [1, 2, 4]
""",
    "references": """
scenes = ["refocus", "sphere1"]
seeds = 1
[vary]
"medium.sigma_s" = [0.1, 0.15, 0.2, 0.3]
""",
}


def run(spec: str, workers: int, cores: str) -> dict:
    """One cold sweep with ``workers`` local processes: wall seconds, the references'
    batch seconds and the points' seconds."""
    pin = None
    if cores == "one":
        pin = list(sorted(os.sched_getaffinity(0)))[:workers]
        if len(pin) < workers:
            raise SystemExit(f"--cores one: {workers} workers need {workers} cores, this machine gives {len(pin)}")
    with tempfile.TemporaryDirectory() as root:
        env = {**os.environ, "VOLCAUSTICS_CACHE": os.path.join(root, "cache")}
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "volcaustics", "sweep", spec, "-o", os.path.join(root, "store"),
                               "--workers", str(workers), "--quiet"], env=env, capture_output=True, text=True,
                              preexec_fn=(lambda: os.sched_setaffinity(0, pin)) if pin else None)
        wall = time.perf_counter() - t0
        if done.returncode != 0:
            raise SystemExit(done.stdout[-2000:] + done.stderr[-2000:])
        manifests = [json.load(open(p)) for p in glob.glob(os.path.join(root, "cache", "reference", "*.json"))]
        points = [json.load(open(p))["experiment_seconds"]["total"]
                  for p in glob.glob(os.path.join(root, "store", "points", "*", "summary.json"))]
    processes = {name for m in manifests for name in m.get("rendered_by", {})}
    return {"workers": workers, "wall": wall, "references": sum(m.get("wall_seconds", 0.0) for m in manifests),
            "count": len(manifests), "processes": len(processes), "points": points}


def report(name: str, cores: str, one: dict, two: dict, projected: int) -> None:
    speedup = one["wall"] / two["wall"]
    parallel = min(max(2.0 * (1.0 - 1.0 / speedup), 0.0), 1.0)  # Amdahl's p from the 1 → 2 speed-up
    n = len(one["points"])
    print(f"\n{name} sweep, cores {cores}: {n} points, {one['count']} references rendered cold per run")
    print(f"{'workers':>7} {'wall s':>8} {'references s':>13} {'rendered by':>12} {'points s (sum)':>15}")
    for r in (one, two):
        print(f"{r['workers']:>7} {r['wall']:>8.1f} {r['references']:>13.1f} {r['processes']:>12} "
              f"{sum(r['points']):>15.1f}")
    print(f"speed-up 1 -> 2 workers: {speedup:.2f}x; Amdahl: parallel share p = {parallel:.2f}, "
          f"serial share {1 - parallel:.2f}")
    point = sum(one["points"]) / n
    serial = max(0.0, one["wall"] - sum(one["points"]) - one["references"])
    print(f"one worker: references {one['references'] / one['wall']:.0%}, points {sum(one['points']) / one['wall']:.0%}"
          f", the rest (start-up, consolidation) {serial:.1f} s")
    print(f"projection for {projected} points of this size ({point:.1f} s each) and that rest, every machine "
          f"like this run's one worker:")
    for machines in (1, 2, 4, 8, 16, 32):
        total = serial + projected * point / machines
        print(f"  {machines:>3} machines: {total / 60:7.1f} min ({serial / total:.0%} serial)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sweeps", default="mixed,references", help="which sweeps (default mixed,references)")
    parser.add_argument("--cores", default="shared,one", help="how the workers get cores (default shared,one)")
    parser.add_argument("--size", type=int, default=128, help="image side of the points (default 128)")
    parser.add_argument("--photon-res", type=int, default=256, help="photon_res of the points (default 256)")
    parser.add_argument("--points-projected", type=int, default=644, help="the projected sweep's points "
                        "(default 644: the variants sweep)")
    args = parser.parse_args()
    for name in args.sweeps.split(","):
        with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as fh:
            fh.write(SWEEPS[name] + COMMON.format(size=args.size, photon_res=args.photon_res))
            spec = fh.name
        for cores in args.cores.split(","):
            one, two = run(spec, 1, cores), run(spec, 2, cores)
            report(name, cores, one, two, args.points_projected)
        os.unlink(spec)
    return 0


if __name__ == "__main__":
    sys.exit(main())
