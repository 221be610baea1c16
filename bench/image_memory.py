"""Bytes per pixel of each command's images: the constants that check image sizes
against memory (``approx.limits.IMAGE_BYTES_PER_PIXEL``,
``reference.settings.IMAGE_BYTES_PER_PIXEL``, ``experiment.point_checks``).

    .venv/bin/python bench/image_memory.py [approx reference measure compare] [--sizes 1024,2048] [--seeds 1,2,4]

Each command runs in its own process on sphere1 at two square sizes with everything
else tiny (photon_res 8, light_res 16; a reference of 20,000 photons, 2 spp, 2
batches); its peak resident memory (``ru_maxrss``) is read, and the slope between the
sizes is the cost per pixel (the fixed part, libraries and meshes, cancels). ``compare``
reads that many of the approximation's EXRs (written first, one seed each). Use a
private cache: ``VOLCAUSTICS_CACHE=$(mktemp -d)``. Figures: docs/decisions.md
"Image sizes against memory".
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

EXE = os.path.join(os.path.dirname(sys.executable), "volcaustics")
TINY = ["--photon-res", "8", "--light-res", "16"]
REFERENCE = ["--photons", "20000", "--spp", "2", "--batches", "2"]


def peak_bytes(argv) -> int:
    """Peak resident bytes of ``volcaustics argv`` (it must exit 0)."""
    proc = subprocess.Popen([EXE, *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(argv)}: {proc.stderr.read().decode()[-500:]}")
    return usage.ru_maxrss * 1024


def argv_of(command: str, size: int, seeds: int, out: str) -> list:
    s = str(size)
    square = ["--width", s, "--height", s]
    if command == "approx":
        return ["approx", "sphere1", "-o", f"{out}/a{s}.exr", *square, *TINY]
    if command == "reference":
        return ["reference", "sphere1", "-o", f"{out}/r{s}.exr", *square, *REFERENCE, "--force"]
    if command == "compare":
        files = [f"{out}/c{s}-{seed}.exr" for seed in range(seeds)]
        for seed, path in enumerate(files):
            peak_bytes(["approx", "sphere1", "-o", path, *square, *TINY, "--seed", str(seed)])
        return ["compare", "sphere1", *files, "-o", f"{out}/c{s}", *REFERENCE, "--target-noise", "none",
                "--max-scatter", "1", "--quiet"]
    return ["measure", "sphere1", "-o", f"{out}/m{s}", *square, *TINY, *REFERENCE, "--target-noise", "none",
            "--seeds", str(seeds), "--quiet"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("commands", nargs="*", default=["approx", "reference", "measure"])
    ap.add_argument("--sizes", default="1024,2048", help="two square sizes (measure: use 256,512)")
    ap.add_argument("--seeds", default="1,2,4", help="measure's and compare's seed counts")
    args = ap.parse_args()
    small, large = (int(x) for x in args.sizes.split(","))
    out = tempfile.mkdtemp()
    for command in args.commands:
        for seeds in [int(x) for x in args.seeds.split(",")] if command in ("measure", "compare") else [1]:
            a, b = (peak_bytes(argv_of(command, n, seeds, out)) for n in (small, large))
            per_pixel = (b - a) / (large * large - small * small)
            label = f"{command}" + (f" ({seeds} seeds)" if command in ("measure", "compare") else "")
            print(f"{label:<20} {a / 2**20:7.0f} MiB at {small}², {b / 2**20:7.0f} MiB at {large}²: "
                  f"{per_pixel:6.0f} B per pixel", flush=True)


if __name__ == "__main__":
    main()
