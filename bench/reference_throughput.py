"""Reference throughput.

    .venv/bin/python bench/reference_throughput.py

1. Photon paths per second of the volumetric light tracer (``surface`` mode) vs
   Mitsuba's C++ ``ptracer`` (max_depth 2) on the same surface-only scene, in one run
   (target ratio ≥ 0.5). Each integrator renders once to compile its kernels, then
   three timed renders; medians.
2. Wall time for the ``refocus`` caustic at 256² to reach relative MSE < 1%
   (Σ(a − b)² / Σ b²) against a render with 4× the photons.
"""

from __future__ import annotations

import os
import statistics
import sys
import time

import numpy as np

os.environ.setdefault("VOLCAUSTICS_MI_VARIANT", "llvm_ad_rgb")


def _timed(mi, scene, integrator, spp, seed):
    t0 = time.perf_counter()
    image = np.asarray(mi.render(scene, integrator=integrator, seed=seed, spp=spp))
    return time.perf_counter() - t0, image


def throughput():
    from volcaustics.reference.mi_setup import mitsuba
    from volcaustics.reference.render.export import to_mitsuba
    from volcaustics.reference.render.integrators import VolumetricLightTracer, configure
    from volcaustics.scenes.model import Camera, DiffuseSurface, MeshSpec, Scene, SpotLight, Transform

    mi = mitsuba()
    cam = Camera(position=(0.0, 1.6, 3.0), target=(0.0, 0.3, 0.0), fov_y=40.0, width=256, height=256)
    ball = DiffuseSurface("ball", MeshSpec(generator="sphere", params=(("radius", 0.35), ("subdivisions", 24)),
                                           transform=Transform(translate=(0.0, 0.6, 0.0))), (0.8, 0.5, 0.3))
    floor = DiffuseSurface("floor", MeshSpec(generator="quad", params=(("size_x", 4.0), ("size_z", 4.0))), (0.6,) * 3)
    scene = Scene(name="bench", camera=cam,
                  light=SpotLight((0.3, 2.5, 0.2), (-0.14, -0.98, -0.1), (10.0,) * 3, 35.0, 25.0),
                  diffuse=(ball, floor))
    mi_scene = mi.load_dict(to_mitsuba(scene))
    props = mi.Properties()
    props["mode"] = "surface"
    ours = configure(VolumetricLightTracer(props), scene, mi_scene)
    theirs = mi.load_dict({"type": "ptracer", "max_depth": 2})
    spp = 64
    paths = spp * cam.width * cam.height
    rates = {}
    for name, integ in (("vc_lighttracer", ours), ("ptracer", theirs)):
        _timed(mi, mi_scene, integ, spp, 0)  # compile
        times = [_timed(mi, mi_scene, integ, spp, s)[0] for s in range(1, 4)]
        rates[name] = paths / statistics.median(times)
    print(f"[throughput] surface-only scene, {paths:,} paths per render ({mi.variant()})")
    for name, rate in rates.items():
        print(f"  {name:<15} {rate / 1e6:8.2f} M paths/s")
    print(f"  ratio vc_lighttracer / ptracer = {rates['vc_lighttracer'] / rates['ptracer']:.2f} (target >= 0.5)")


def convergence():
    import dataclasses

    from volcaustics.metrics.image import relative_mse
    from volcaustics.reference.render import render_batches
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes import load_builtin

    scene = load_builtin("refocus")
    base = ReferenceSettings(photons=1 << 20, spp=8, batches=2, width=256, height=256)
    print("[convergence] refocus caustic at 256x256, relative MSE vs 4x the photons")
    photons = base.photons
    while True:
        t0 = time.perf_counter()
        low = render_batches(scene, dataclasses.replace(base, photons=photons, seed=1), progress=False)
        seconds = time.perf_counter() - t0
        high = render_batches(scene, dataclasses.replace(base, photons=4 * photons, seed=2), progress=False)
        err = relative_mse(high["caustic"][0], low["caustic"][0])
        print(f"  {photons:>12,} photons: {seconds:6.1f} s, relative MSE {100 * err:.2f}%")
        if err < 0.01 or photons >= 1 << 28:
            break
        photons *= 2
    print(f"  -> relative MSE < 1% after {seconds:.1f} s ({photons:,} photons)")


def main() -> int:
    throughput()
    convergence()
    return 0


if __name__ == "__main__":
    sys.exit(main())
