"""Lost power and caustic energy of the approximation against the ground truth.

    .venv/bin/python bench/agreement.py [SCENE ...] [--photon-res 512] [--size 256]

For each scene and two tracer settings (deterministic Fresnel with 4 steps,
stochastic with 16), prints

* lost: the share of the power entering step 1 that ends ``lost`` (inside glass,
  no exit found), for the approximation and for the exact photon tracer replaying
  the same photons (reference.oracle.exact_photon_records);
* left_frustum: the share of segments flagged FLAG_LEFT_FRUSTUM;
* caustic approx / reference: caustic energy over the pixels that do not see glass,
  against the cached reference (2^22 photons, 4 batches, like ``make report``),
  with the reference's standard deviation of that total.

It gives these figures before and after the agreement fixes.
"""

from __future__ import annotations

import argparse
import sys


def power_share(records: list, status: int) -> float:
    """Share of the step-1 power (mean over RGB) that ends a step with ``status``."""

    total = float(records[0]["power_start"].mean(axis=1).sum())
    ended = sum(float(r["power_start"][r["status"] == status].mean(axis=1).sum()) for r in records)
    return ended / total if total > 0 else float("nan")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=["sphere1", "bunny", "skull"])
    parser.add_argument("--photon-res", type=int, default=512)
    parser.add_argument("--light-res", type=int, default=1024)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--clip-to-objects", action="store_true",
                        help="also clip searched segments to the specular objects' box (the CLIP_TO_OBJECTS control)")
    args = parser.parse_args(argv)

    import numpy as np

    import volcaustics.reference  # noqa: F401  (libLLVM before drjit)
    from volcaustics.approx import ApproxParams, Renderer
    from volcaustics.reference.oracle import Oracle, exact_photon_records
    from volcaustics.reference.render import render_reference
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.formats import FLAG_LEFT_FRUSTUM, STATUS_LOST

    settings = ReferenceSettings(photons=1 << 22, spp=64, batches=4, width=args.size, height=args.size)
    print(f"photon_res {args.photon_res}, light_res {args.light_res}, {args.size}², "
          f"reference {settings.photons} photons"
          f"{', clipped to the objects box' if args.clip_to_objects else ''}")
    print(f"{'scene':10} {'fresnel':13} {'steps':>5} {'lost approx':>11} {'lost exact':>10} "
          f"{'left_frustum':>12} {'caustic approx/ref':>18} {'trace s':>7}")
    for name in args.scenes:
        scene = resolve_scene(name)
        ref = render_reference(scene, settings, progress=False)
        keep = ref.mean["mask_specular"][..., 0] < 0.5
        ref_total = float(ref.mean["caustic"][keep].sum())
        ref_sd = float(np.sqrt(ref.var["caustic"][keep].sum()))
        renderer = Renderer(scene, controls={"CLIP_TO_OBJECTS": 1} if args.clip_to_objects else None)
        oracle = Oracle(scene)
        for fresnel, steps in (("deterministic", 4), ("stochastic", 16)):
            params = ApproxParams(photon_res=args.photon_res, light_res=args.light_res, width=args.size,
                                  height=args.size, steps=steps, fresnel=fresnel, splat_radius=0.02)
            renderer.render(params=params, keep_records=False)  # compile shaders; time the next frame
            frame = renderer.render(params=params)
            exact = exact_photon_records(scene, frame.records[0], steps=steps, seed=params.seed, fresnel=fresnel,
                                         oracle=oracle)
            flagged = sum(int(((r["flags"] & FLAG_LEFT_FRUSTUM) > 0).sum()) for r in frame.records)
            segments = sum(len(r) for r in frame.records)
            ratio = float(frame.images["caustic"][keep].sum()) / ref_total
            print(f"{name:10} {fresnel:13} {steps:5d} {100 * power_share(frame.records, STATUS_LOST):10.2f}% "
                  f"{100 * power_share(exact, STATUS_LOST):9.2f}% {100 * flagged / segments:11.2f}% "
                  f"{ratio:11.3f} ± {ref_sd / ref_total:.3f} {frame.timings['trace']:7.2f}", flush=True)
        renderer.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
