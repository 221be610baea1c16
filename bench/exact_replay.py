"""The exact replay against the machine's ray-casting bound.

    .venv/bin/python bench/exact_replay.py [SCENE ...] [--seeds 6] [--subphotons 16]

For each scene, at the report's settings (quick preset, the report's seeds and
sub-photons): the frames, then the E_∞ replays of the decomposition
(``experiment.exact_images.replayed``: A's emission with A's Fresnel and, for a
deterministic Fresnel, with the stochastic one, and the light's true emission, every
seed and sub-photon as one wavefront per Fresnel mode, each from the emission ray), timed,
then once more with their rays kept (``Oracle.segments``). Then, in the same process, the
raw bound: one
``scene.ray_intersect`` on the very same segments, with only the hit distance evaluated
(the machine's ray-casting bound), with the fields the replay reads (t, shape, normals:
"needed") and with the whole interaction. Prints rays, seconds,
M rays/s and the replay's ratio to each (the budget: the replay at ≥ 1/3 of the bound).
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def raw_throughput(oracle, segments: list) -> dict:
    """M rays/s of one ``scene.ray_intersect`` on ``segments`` ((start, direction,
    length) float32 arrays per query): with only the hit distance evaluated ("t", what
    any ray caster computes: the machine's bound), with the fields the replay reads
    ("needed": t, hit, shape, shading and geometric normals) and with every field of
    the interaction ("interaction")."""
    import drjit as dr

    mi = oracle.mi
    o, d, L = (np.concatenate(parts) for parts in zip(*segments))
    out = {}
    for what in ("t", "needed", "interaction"):
        ray = mi.Ray3f(mi.Point3f(*o.T), mi.Vector3f(*d.T))
        ray.maxt = mi.Float(L)
        dr.eval(ray)
        dr.sync_thread()
        t0 = time.perf_counter()
        si = oracle.mi_scene.ray_intersect(ray)
        dr.eval(si.t if what == "t" else (si.t, si.is_valid(), si.shape, si.sh_frame.n, si.n) if what == "needed"
                else si)
        dr.sync_thread()
        out[what] = len(L) / (time.perf_counter() - t0) / 1e6
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=["sphere1", "bunny"])
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--subphotons", type=int, default=16)
    args = parser.parse_args(argv)

    import volcaustics.reference  # noqa: F401  (libLLVM before drjit)
    from volcaustics.approx import Renderer
    from volcaustics.approx.emission import true_rays
    from volcaustics.approx.light import LightFrustum
    from volcaustics.approx.params import QUICK
    from volcaustics.experiment.approx_frames import render_frames
    from volcaustics.experiment.exact_images import replay_seed, replayed
    from volcaustics.experiment.measurement import EXACT_STEPS
    from volcaustics.experiment.point_checks import checked_settings
    from volcaustics.reference.oracle import Oracle
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.bounds import medium_bounds

    print(f"{'scene':<12} {'rays':>10} {'replay s':>9} {'replay Mray/s':>14} {'bound (t)':>10} {'ratio':>6} "
          f"{'bound (needed)':>15} {'ratio':>6} {'bound (si)':>11} {'ratio':>6}")
    for name in args.scenes:
        scene = resolve_scene(name)
        p, seeds = checked_settings(scene, QUICK, args.seeds)
        renderer, oracle = Renderer(scene), Oracle(scene)
        frames, _ = render_frames(renderer, scene, p, seeds, warm_up=True)
        frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
        replay_seeds = [[replay_seed(s, m) for m in range(args.subphotons)] for s in seeds]
        own = [(rays, s) for rays, mine in zip(renderer.emission_rays(scene, p, seeds), replay_seeds) for s in mine]
        true = [(true_rays(scene.light, frustum, p.photon_res, s), s) for mine in replay_seeds for s in mine]
        replayed(scene, p, p.fresnel, own[:1], oracle, EXACT_STEPS)  # compiles the kernels
        timings = []
        for kept in (None, []):  # timed, then again keeping its rays (deterministic: the same ones) for the bound
            oracle.rays, oracle.segments = 0, kept
            t0 = time.perf_counter()
            if p.fresnel != "stochastic":
                replayed(scene, p, p.fresnel, own, oracle, EXACT_STEPS)
            replayed(scene, p, "stochastic", own + true, oracle, EXACT_STEPS)
            timings.append((time.perf_counter() - t0, oracle.rays))
        seconds, rays = timings[0]
        bound = raw_throughput(oracle, oracle.segments)
        replay = rays / seconds / 1e6
        print(f"{name:<12} {rays:>10,} {seconds:>9.2f} {replay:>14.2f} {bound['t']:>10.2f} {replay / bound['t']:>6.2f} "
              f"{bound['needed']:>15.2f} {replay / bound['needed']:>6.2f} {bound['interaction']:>11.2f} "
              f"{replay / bound['interaction']:>6.2f}")
        renderer.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
