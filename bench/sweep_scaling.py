"""A cold sweep's scaling with workers: the same sweep with 1 and with 2 local worker
processes, each from an empty cache (its references render too), the speed-up between
them, the share of the time that stays serial (Amdahl: 1/S = (1 − p) + p/N), and the
projection for N machines of a sweep of P points.

    .venv/bin/python bench/sweep_scaling.py [--scenes refocus,sphere1] [--size 128] [--photon-res 256]
                                            [--points-projected 644]

Where the serial time goes is read from the runs themselves: the references' render
seconds (their manifests) and the points' own seconds (their summaries). Figures:
docs/decisions.md "Sweep scaling".
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

SPEC = """
scenes = {scenes}
seeds = 2
[vary]
layers = [1, 2, 4]
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


def run(spec: str, workers: int) -> dict:
    """One cold sweep with ``workers`` local processes: wall seconds, the references'
    render seconds and the points' seconds."""
    with tempfile.TemporaryDirectory() as root:
        env = {**os.environ, "VOLCAUSTICS_CACHE": os.path.join(root, "cache")}
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "volcaustics", "sweep", spec, "-o", os.path.join(root, "store"),
                               "--workers", str(workers), "--quiet"], env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if done.returncode != 0:
            raise SystemExit(done.stdout[-2000:] + done.stderr[-2000:])
        references = [json.load(open(p)).get("wall_seconds", 0.0)
                      for p in glob.glob(os.path.join(root, "cache", "reference", "*.json"))]
        points = [json.load(open(p))["experiment_seconds"]["total"]
                  for p in glob.glob(os.path.join(root, "store", "points", "*", "summary.json"))]
    return {"workers": workers, "wall": wall, "references": sum(references), "points": points}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default="refocus,sphere1")
    parser.add_argument("--size", type=int, default=128, help="image side of the points (default 128)")
    parser.add_argument("--photon-res", type=int, default=256, help="photon_res of the points (default 256)")
    parser.add_argument("--points-projected", type=int, default=644, help="the projected sweep's points "
                        "(default 644: the variants sweep)")
    args = parser.parse_args()
    scenes = [s.strip() for s in args.scenes.split(",")]
    with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as fh:
        fh.write(SPEC.format(scenes=json.dumps(scenes), size=args.size, photon_res=args.photon_res))
        spec = fh.name
    one, two = run(spec, 1), run(spec, 2)
    os.unlink(spec)
    speedup = one["wall"] / two["wall"]
    parallel = min(max(2.0 * (1.0 - 1.0 / speedup), 0.0), 1.0)  # Amdahl's p from the 1 → 2 speed-up
    n = len(one["points"])
    print(f"{n} points over {len(scenes)} scenes, references cold ({sum(1 for _ in scenes)} rendered per run)")
    print(f"{'workers':>7} {'wall s':>8} {'references s':>13} {'points s (sum)':>15}")
    for r in (one, two):
        print(f"{r['workers']:>7} {r['wall']:>8.1f} {r['references']:>13.1f} {sum(r['points']):>15.1f}")
    print(f"speed-up 1 -> 2 workers: {speedup:.2f}x; Amdahl: parallel share p = {parallel:.2f}, "
          f"serial share {1 - parallel:.2f}")
    print(f"of the one-worker run: references {one['references'] / one['wall']:.0%} (serial: rendered in the "
          f"sweep's process), points {sum(one['points']) / one['wall']:.0%}")
    point = sum(one["points"]) / n
    serial = one["wall"] - sum(one["points"])
    print(f"projection for {args.points_projected} points of this size ({point:.1f} s each) and this serial time "
          f"({serial:.1f} s), as if every machine were this one:")
    for machines in (1, 2, 4, 8, 16, 32):
        total = serial + args.points_projected * point / machines
        print(f"  {machines:>3} machines: {total / 60:7.1f} min ({serial / total:.0%} serial)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
