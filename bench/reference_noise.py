"""Time to the noise floor: how long the ground truth takes to reach its targets.

    .venv/bin/python bench/reference_noise.py [SCENE ...] [--size 256]
        [--target-noise caustic=0.005,fog=0.002,direct=0.002] [--max-seconds 120]

Renders each scene's reference afresh (not from the cache; nothing is stored)
with the main job's batch size (experiment/sizing.py) until every component's
noise floor — Σ var / Σ mean² over non-glass pixels — is at its target or the
time cap passes, and prints per component the floor reached, the render time at
which it first met its target, the batches and photons, and what stopped it.
``--target-noise none`` renders the fixed budget instead (photons/batches as given).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys


def main(argv=None) -> int:
    from volcaustics.experiment.sizing import REPORT_REFERENCE, REPORT_TARGET

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*",
                        default=["sphere1", "sphere2", "bunny", "feline", "skull", "two_spheres", "refocus"])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--target-noise", default=REPORT_TARGET)
    parser.add_argument("--max-seconds", type=float, default=REPORT_REFERENCE.max_seconds)
    parser.add_argument("--photons", type=int, default=REPORT_REFERENCE.photons)
    parser.add_argument("--batches", type=int, default=REPORT_REFERENCE.batches)
    args = parser.parse_args(argv)

    import volcaustics.reference  # noqa: F401  (libLLVM before drjit)
    from volcaustics.reference.render import render_batches
    from volcaustics.scenes import resolve_scene

    target = None if args.target_noise.lower() == "none" else args.target_noise
    settings = dataclasses.replace(REPORT_REFERENCE, width=args.size, height=args.size, target_noise=target,
                                   max_seconds=args.max_seconds, photons=args.photons, batches=args.batches)
    print(f"{args.size}², batch: {settings.photons // settings.batches:,} photons and "
          f"{settings.spp // settings.batches} camera spp; at least {settings.batches} batches; "
          f"target {settings.targets() or 'none'}; cap {settings.max_seconds:g} s")
    print(f"{'scene':12} {'component':9} {'floor':>8} {'target':>7} {'s to target':>11} {'batches':>7} "
          f"{'photons':>13} {'seconds':>7}  stopped by")
    for name in args.scenes:
        out = render_batches(resolve_scene(name), settings, progress=False)
        info = out["_info"]
        for component in ("caustic", "fog", "direct"):
            floor = info["noise_floor"][component]
            target_value = settings.targets().get(component)
            reached = info["seconds_to_target"].get(component)
            batches = info["batches"] if component == "caustic" else info["camera_batches"]
            seconds = f"{reached['seconds']:.1f}" if reached else "-"
            print(f"{name:12} {component:9} {_pct(floor):>8} {_pct(target_value):>7} "
                  f"{seconds:>11} {batches:7d} "
                  f"{info['photons'] if component == 'caustic' else 0:13,d} {info['seconds']:7.1f}  "
                  f"{info['stopped_by']}", flush=True)
    return 0


def _pct(value) -> str:
    return "-" if value is None else f"{100 * value:.3f}%"


if __name__ == "__main__":
    sys.exit(main())
