"""The reference caustic's noise floor and render time per built-in scene.

    .venv/bin/python bench/reference_fireflies.py [SCENE ...] [--photons N] [--batches B] [--size S]
        [--geometry-per-connection K[,K...]] [--cause]

For each scene, at the report's settings (2^22 photons in 4 batches, 256², seeds
0..B−1 as ``reference.render`` uses them), the light tracer's caustic alone:

* ``floor``: Σ var / Σ mean² over the pixels that do not see glass, var the variance
  of the mean over the batches (docs/concepts/measuring.md;
* ``top 0.1%``: the share of that Σ var held by the 0.1% largest pixel-channel
  variances (fireflies: 81% on bunny before the fix, a few % for noise without them);
* ``energy``: Σ mean over the same pixels, with its standard error over the batches;
* ``seconds``: wall time of the B batches, after one small render has compiled the kernels.

The script only uses what every version of ``reference`` has, so it measures a
checkout before a change as well as after (``git archive COMMIT | tar -x -C DIR``,
then ``PYTHONPATH=DIR``). ``--geometry-per-connection`` sweeps the light tracer's
property of that name (one row per value). Timings on a shared machine move with
its load: compare runs made back to back.

``--cause`` (this version on) also renders the estimator the fireflies came from —
one equiangular connection on the whole segment — once in full and once per class
of segments: by the angle Δθ the segment subtends at the eye and by its line's
distance D to the eye. Per class: its share of the caustic's energy and of Σ var
(each class is its own independent render, so shares add up only roughly).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

os.environ.setdefault("VOLCAUSTICS_MI_VARIANT", "llvm_ad_rgb")

SCENES = ("sphere1", "sphere2", "bunny", "feline", "skull", "two_spheres", "refocus")


def measure(name: str, photons: int, batches: int, size: int, geometry_per_connection: float | None) -> dict:
    from volcaustics.reference.mi_setup import mitsuba
    from volcaustics.reference.render.camera_integrator import SingleScatterIntegrator
    from volcaustics.reference.render.export import load_scene
    from volcaustics.reference.render.integrators import VolumetricLightTracer, configure
    from volcaustics.reference.request import resolve
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes import resolve_scene

    mi = mitsuba()
    settings = ReferenceSettings(photons=photons, spp=batches, batches=batches, width=size, height=size)
    request = resolve(resolve_scene(name), settings, "caustic")
    mi_scene = load_scene(mi, request.description)
    props = mi.Properties()
    props["mode"] = "caustic"
    if geometry_per_connection is not None:
        props["geometry_per_connection"] = geometry_per_connection
    tracer = configure(VolumetricLightTracer(props), request.scene, mi_scene)
    camera = configure(SingleScatterIntegrator(), request.scene, mi_scene)
    glass = np.asarray(mi.render(mi_scene, integrator=camera, seed=0, spp=4))[..., 9] > 0.5
    spp = max(1, math.ceil(photons / batches / (size * size)))
    mi.render(mi_scene, integrator=tracer, seed=10_000, spp=1)  # compile
    t0 = time.perf_counter()
    images = np.stack([np.asarray(mi.render(mi_scene, integrator=tracer, seed=b, spp=spp))[..., :3]
                       for b in range(batches)]).astype(np.float64)
    seconds = time.perf_counter() - t0
    pixels = images[:, ~glass]                       # B × N × 3
    mean, var = pixels.mean(0), pixels.var(0, ddof=1) / batches
    ranked = np.sort(var.ravel())[::-1]
    totals = pixels.sum(axis=(1, 2))
    return {"scene": name, "floor": float(var.sum() / (mean ** 2).sum()),
            "top": float(ranked[: max(1, ranked.size // 1000)].sum() / ranked.sum()),
            "energy": float(totals.mean()), "energy_se": float(totals.std(ddof=1) / math.sqrt(batches)),
            "seconds": seconds, "photons": spp * size * size * batches,
            "geometry_per_connection": getattr(tracer, "geometry_per_connection", None)}


ANGLE_CLASSES = ((0.0, 1.0), (1.0, 2.0), (2.0, 4.0))    # Δθ in rad
DISTANCE_CLASSES = ((0.0, 0.1), (0.1, 0.5), (0.5, 1e9))  # D in m


def cause(name: str, photons: int, batches: int, size: int) -> list:
    """Energy and Σ var shares of the single-connection estimator's segment classes."""
    import drjit as dr

    from volcaustics.reference.mi_setup import mitsuba
    from volcaustics.reference.render.camera_integrator import SingleScatterIntegrator
    from volcaustics.reference.render.export import load_scene
    from volcaustics.reference.render.integrators import VolumetricLightTracer, configure
    from volcaustics.reference.render.sampling import subtended_angle
    from volcaustics.reference.request import resolve
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes import resolve_scene

    mi = mitsuba()

    class SingleConnection(VolumetricLightTracer):
        """One equiangular connection on the whole segment, for segments of one class."""

        angle, distance = (0.0, 4.0), (0.0, 1e9)

        def connections(self, view, ray, t_end):
            angle, dist = subtended_angle(ray.o, ray.d, t_end, view.eye)
            chosen = ((angle >= self.angle[0]) & (angle < self.angle[1]) & (dist >= self.distance[0])
                      & (dist < self.distance[1]))
            return dr.zeros(mi.Float, dr.width(t_end)), t_end, chosen, dr.full(mi.UInt32, 1, dr.width(t_end))

    settings = ReferenceSettings(photons=photons, spp=batches, batches=batches, width=size, height=size)
    request = resolve(resolve_scene(name), settings, "caustic")
    mi_scene = load_scene(mi, request.description)
    props = mi.Properties()
    props["mode"] = "caustic"
    tracer = configure(SingleConnection(props), request.scene, mi_scene)
    camera = configure(SingleScatterIntegrator(), request.scene, mi_scene)
    glass = np.asarray(mi.render(mi_scene, integrator=camera, seed=0, spp=4))[..., 9] > 0.5
    spp = max(1, math.ceil(photons / batches / (size * size)))

    def render(angle, distance):
        tracer.angle, tracer.distance = angle, distance
        images = np.stack([np.asarray(mi.render(mi_scene, integrator=tracer, seed=b, spp=spp))[..., :3]
                           for b in range(batches)]).astype(np.float64)[:, ~glass]
        return images.mean(0).sum(), (images.var(0, ddof=1) / batches).sum(), (images.mean(0) ** 2).sum()

    energy, var, mean2 = render((0.0, 4.0), (0.0, 1e9))
    rows = [("all segments", 1.0, 1.0, var / mean2)]
    for lo, hi in ANGLE_CLASSES:
        e, v, _ = render((lo, hi), (0.0, 1e9))
        rows.append((f"angle {lo:g}-{hi:g} rad", e / energy, v / var, None))
    for lo, hi in DISTANCE_CLASSES:
        e, v, _ = render((0.0, 4.0), (lo, hi))
        rows.append((f"D {lo:g}-{hi:g} m" if hi < 1e9 else f"D > {lo:g} m", e / energy, v / var, None))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", default=list(SCENES))
    parser.add_argument("--photons", type=int, default=1 << 22)
    parser.add_argument("--batches", type=int, default=4)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--geometry-per-connection", default=None,
                        help="comma-separated values of the light tracer's property (1/m); default: its own")
    parser.add_argument("--cause", action="store_true",
                        help="also split the single-connection estimator's noise by segment class")
    args = parser.parse_args(argv)
    values = [None] if args.geometry_per_connection is None else [float(v) for v in
                                                                 args.geometry_per_connection.split(",")]
    from volcaustics.reference.mi_setup import mitsuba

    print(f"caustic of the light tracer, {args.size}x{args.size}, {args.photons:,} photons in {args.batches} "
          f"batches, {mitsuba().variant()}, {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}")
    print(f"{'scene':<12} {'g/conn 1/m':>10} {'floor':>10} {'top 0.1%':>9} {'energy':>18} {'seconds':>8}")
    for name in args.scenes:
        for value in values:
            r = measure(name, args.photons, args.batches, args.size, value)
            g = "-" if r["geometry_per_connection"] is None else f"{r['geometry_per_connection']:g}"
            print(f"{r['scene']:<12} {g:>10} {100 * r['floor']:9.4f}% {100 * r['top']:8.1f}% "
                  f"{r['energy']:10.3f} ± {r['energy_se']:5.3f} {r['seconds']:8.2f}", flush=True)
    if args.cause:
        print("\nsingle connection on the whole segment (the unstratified estimator), by segment class")
        print(f"{'scene':<12} {'class':<18} {'energy':>8} {'sum var':>8}")
        for name in args.scenes:
            for label, energy, var, floor in cause(name, args.photons, args.batches, args.size):
                extra = f"  (floor {100 * floor:.3f}%)" if floor is not None else ""
                print(f"{name:<12} {label:<18} {100 * energy:7.2f}% {100 * var:7.1f}%{extra}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
