"""What no search can find: the exact hits of wrong-surface and missed segments that no
light map holds.

    .venv/bin/python bench/absent_surfaces.py [SCENE ...] [--strategies threshold,peel] [--layers 4,8]
        [--set NAME=VALUE ...]

A search reads the light maps; a surface no map holds at the point where the segment
meets it cannot be found by any search (`search`) or start rule, only by other maps
(`layer_strategy`, `layers`). For every segment of the quick preset (one seed,
deterministic Fresnel, all steps) the exact oracle answers on the same interval
(`volcaustics.metrics.intersection.classify_segments`; a self re-hit of the start surface
takes the class of what lies beyond it, as in the harness's tables); for each
wrong-surface and missed segment, the exact hit point is looked up in every map: the
hit is *held* when some map's texel under it stores a distance within
max(2 footprints · (1 + tan θ), 1e-4 m) of the hit's distance to the light (θ: the
angle between the light ray and the surface normal; 2 footprints: the texel centre's
ray against the hit's, and rounding), else *absent*. Printed per scene, strategy and
layers: the step-2 class shares and, for wrong-surface and missed segments of all
steps, the share whose exact surface is absent from every map, and of the wrong-surface
hits those before the exact one (early: a crossing where there is none, e.g. between
samples on two different surfaces; else late: the true crossing passed over) and the early
ones on a surface facing as the start surface (shading normals within 18°: its
neighbourhood found again beyond the start offset) and the other early ones where the
segment is not at the winning texel's surface (a jump: f changed sign between texels of
two surfaces, not at a surface); the control: the
share of true hits (found in a map by the search) the lookup calls held.
"""

from __future__ import annotations

import argparse
import sys


def held_in_maps(points, normals, maps, frustum, res):
    """N bool: does some map (list of res×res distance arrays, rows bottom-up) hold the
    surface at each point (N×3) with outward normal (N×3)?"""
    import numpy as np

    light = np.asarray(frustum.position, np.float64)
    clip = np.c_[points, np.ones(len(points))] @ np.asarray(frustum.view_proj, np.float64).T
    uv = clip[:, :2] / clip[:, 3:4] * 0.5 + 0.5
    inside = np.all((uv >= 0) & (uv < 1), axis=1) & (clip[:, 3] > 0)
    texel = np.clip((uv * res).astype(int), 0, res - 1)
    to_point = points - light
    r = np.linalg.norm(to_point, axis=1)
    cos_t = np.clip(np.abs(np.einsum("ij,ij->i", to_point / r[:, None], normals)), 0.1, 1.0)
    tan_t = np.sqrt(1.0 - cos_t**2) / cos_t
    footprint = 2.0 * frustum.tan_half / res * r
    tolerance = np.maximum(2.0 * footprint * (1.0 + tan_t), 1e-4)
    held = np.zeros(len(points), bool)
    for dist in maps:
        d = dist[texel[:, 1], texel[:, 0]]
        held |= inside & (d > 0) & (np.abs(d - r) <= tolerance)
    return held


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=["bunny", "feline", "skull"])
    parser.add_argument("--strategies", default="threshold,peel")
    parser.add_argument("--layers", default="4,8")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="another parameter for every run, e.g. crossing=surface")
    args = parser.parse_args(argv)
    import numpy as np

    from volcaustics.approx import Renderer
    from volcaustics.approx.layers import read_map
    from volcaustics.approx.light import LightFrustum
    from volcaustics.approx.params import param, preset
    from volcaustics.experiment.segments import beyond, start_normals
    from volcaustics.metrics.intersection import (
        MISSED_INSIDE,
        MISSED_MEDIUM,
        SELF_REHIT,
        TRUE_HIT,
        WRONG_SURFACE,
        classify_segments,
    )
    from volcaustics.reference.oracle import Oracle
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.bounds import medium_bounds

    changes = {}
    for text in args.set:
        name, _, value = text.partition("=")
        changes[name] = param(name).parse(value)
    print(f"quick preset {changes or ''}, seed 0; step 2: class shares of its segments (self: re-hits of the "
          "start surface, classed by what lies beyond); "
          "all steps: wrong-surface (W) and missed (M) segments whose exact surface no map holds")
    print(f"{'scene':8} {'strategy':9} {'layers':>6} | {'step 2: true':>12} {'wrong':>6} {'missed':>6} "
          f"{'self':>6} | {'W':>6} {'absent':>7} {'early':>7} {'start':>7} {'jump':>7} | {'M':>6} {'absent':>7} | "
          f"{'T held':>7}")
    for name in args.scenes:
        scene = resolve_scene(name)
        oracle = Oracle(scene)
        renderer = Renderer(scene)
        frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
        for strategy in args.strategies.split(","):
            for layers in (int(x) for x in args.layers.split(",")):
                p = preset("quick", layer_strategy=strategy, layers=layers, **changes).resolved(scene)
                frame = renderer.render(params=p)
                maps = [read_map(m.surface)[..., 0] for m in
                        renderer.light_maps.render_layers(frustum, p.light_res, p.layers, p.layer_strategy)]
                records = np.concatenate(frame.records)
                exact = oracle.first_hits(records["start"], records["direction"], records["search_length"])
                options = {"texel_angle": 2.0 * frustum.tan_half / p.light_res,
                           "light_position": np.asarray(scene.light.position),
                           "start_normal": np.concatenate(start_normals(frame.records))}
                self_rehit = classify_segments(records, exact, **options)["cls"] == SELF_REHIT
                past = beyond(records, exact, self_rehit, oracle)  # the harness's classes (segments.py)
                classes = classify_segments(records, exact, exact_beyond=past, **options)
                cls = np.where(self_rehit, classes["cls_beyond"], classes["cls"])
                t_exact = np.where(self_rehit, past["t"], exact["t"])
                normal_exact = np.where(self_rehit[:, None], past["normal"], exact["normal"])
                step2 = records["step"] == 2
                n2 = max(step2.sum(), 1)
                share = {c: 100.0 * np.sum(step2 & (cls == c)) / n2 for c in
                         (TRUE_HIT, WRONG_SURFACE, MISSED_INSIDE, MISSED_MEDIUM)}
                share["self"] = 100.0 * np.sum(step2 & self_rehit) / n2
                hit_points = records["start"] + np.nan_to_num(t_exact)[:, None] * records["direction"]
                held = held_in_maps(hit_points, np.nan_to_num(normal_exact), maps, frustum, p.light_res)
                wrong = cls == WRONG_SURFACE
                missed = (cls == MISSED_INSIDE) | (cls == MISSED_MEDIUM)
                absent_w = 100.0 * np.sum(wrong & ~held) / max(wrong.sum(), 1)
                absent_m = 100.0 * np.sum(missed & ~held) / max(missed.sum(), 1)
                early = 100.0 * np.sum(wrong & (records["t"] < t_exact)) / max(wrong.sum(), 1)
                start_n = options["start_normal"]
                on_start = np.einsum("ij,ij->i", np.nan_to_num(start_n), records["normal"]) > 0.95  # 18°
                on_start_share = 100.0 * np.sum(wrong & (records["t"] < t_exact) & on_start) / max(wrong.sum(), 1)
                # a false crossing at a jump: the segment is not at the winning texel's surface
                approx_points = records["start"] + np.nan_to_num(records["t"])[:, None] * records["direction"]
                at_surface = np.zeros(len(records), bool)
                for m, dist in enumerate(maps):
                    mine = records["map"] == m
                    at_surface[mine] = held_in_maps(approx_points[mine], records["normal"][mine], [dist], frustum,
                                                    p.light_res)
                jump = 100.0 * np.sum(wrong & (records["t"] < t_exact) & ~on_start & ~at_surface) / max(wrong.sum(), 1)
                true = cls == TRUE_HIT  # the control: hits the search found in a map are held
                held_true = 100.0 * np.sum(true & held) / max(true.sum(), 1)
                print(f"{name:8} {strategy:9} {layers:6d} | {share[TRUE_HIT]:11.1f}% {share[WRONG_SURFACE]:5.1f}% "
                      f"{share[MISSED_INSIDE] + share[MISSED_MEDIUM]:5.1f}% {share['self']:5.1f}% | "
                      f"{wrong.sum():6d} {absent_w:6.1f}% {early:6.1f}% {on_start_share:6.1f}% {jump:6.1f}% | "
                      f"{missed.sum():6d} {absent_m:6.1f}% | {held_true:6.1f}%",
                      flush=True)
        renderer.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
