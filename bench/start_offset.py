"""The tracer's start offset: false re-hits against skipped hits across light_res.

    .venv/bin/python bench/start_offset.py [SCENE ...] [--light-res 256,512,1024] [--rules old,new,id]

A segment that leaves a surface starts its search a little way out (the start
offset, approx/shaders/common/start_offset.glsl). Too short and the search finds
the surface it leaves again (a false re-hit: the maps hold that surface only to
within a texel); too long and it jumps over real surfaces close by (a skipped
hit: thin walls, nearby objects). For every segment of steps ≥ 2 that starts at a
surface, the exact oracle answers on the same interval, and:

* skipped hit: the exact first hit lies within the start offset on another
  surface (its shading normal differs from the start's by more than 18°; an
  exact hit on the start surface itself is a self re-hit of the approximate start
  point, not a skip), and the approximation did not find it (inside glass, a
  segment with nothing beyond its offset searches within it: FLAG_WITHIN_OFFSET);
* false re-hit: the approximation hits the surface it started on (normal within
  18° of the start's) where the exact first hit is not within 3 texel footprints.

Shares are of those segments, for the rule in approx/trace.py (``new``), the
former constant offset of 5 texel footprints (``old``) and the start rules ``id``
(no offset; crossings onto the start triangle passed over) and ``facing`` (no
offset; crossings onto faces the photon cannot meet from its side passed over),
stochastic Fresnel, 6 steps. Under ``id`` and ``facing`` a skipped hit is counted
within the offset the ``new`` rule would have used (from the start's shading
normal), so the rules are compared over the same near range.
"""

from __future__ import annotations

import argparse
import sys

SAME_SURFACE = 0.95  # cosine between normals: the same surface (18°)
OLD_RULE = {"START_SLOPE": 0.0, "START_FLOOR": 1e9, "START_MAX": 5.0}  # always 5 footprints


def new_rule_offset(seg, start_normal, texel_angle, light_position, rule):
    """The start offset (m) the offset rule ``rule`` (START_SLOPE/FLOOR/MAX) gives these
    segments (common/start_offset.glsl, with the start's shading normal)."""
    import numpy as np

    to_start = seg["start"] - light_position
    distance = np.linalg.norm(to_start, axis=1)
    cos_theta = np.abs(np.einsum("ij,ij->i", to_start / distance[:, None], start_normal))
    sin_theta = np.sqrt(np.maximum(1.0 - cos_theta**2, 0.0))
    away = np.maximum(np.abs(np.einsum("ij,ij->i", seg["direction"], start_normal)), 1e-6)
    footprints = np.minimum((rule["START_SLOPE"] * sin_theta + rule["START_FLOOR"]) / away, rule["START_MAX"])
    return footprints * texel_angle * distance


def classify(records: list, oracle, texel_angle: float, light_position, window_rule=None) -> dict:
    """Counts of surface-start segments, skipped hits and false re-hits over steps ≥ 2.
    ``window_rule``: count skips within that offset rule's offset (start rule ``id``,
    which has none) instead of the segment's own."""
    import numpy as np

    counts = {"segments": 0, "skipped": 0, "false_rehit": 0}
    for prev, rec in zip(records[:-1], records[1:]):
        k = np.searchsorted(prev["photon"], rec["photon"])
        from_surface = prev["hit"][k]
        seg, start_normal = rec[from_surface], prev["normal"][k][from_surface]
        if len(seg) == 0:
            continue
        q = oracle.first_hits(seg["start"], seg["direction"], seg["search_length"])
        exact_same = np.einsum("ij,ij->i", np.nan_to_num(q["normal"]), start_normal) > SAME_SURFACE
        approx_same = np.einsum("ij,ij->i", np.nan_to_num(seg["normal"]), start_normal) > SAME_SURFACE
        hit_point = seg["start"] + seg["direction"] * np.nan_to_num(seg["t"])[:, None]
        tolerance = 3.0 * texel_angle * np.linalg.norm(hit_point - light_position, axis=1)
        agrees = q["hit"] & seg["hit"] & (np.abs(np.nan_to_num(q["t"]) - np.nan_to_num(seg["t"])) <= tolerance)
        window = seg["start_offset"] if window_rule is None else new_rule_offset(
            seg, start_normal, texel_angle, light_position, window_rule)
        skipped = q["hit"] & (q["t"] < window) & ~exact_same & ~agrees
        rehit = seg["hit"] & approx_same & ~agrees
        counts["segments"] += len(seg)
        counts["skipped"] += int(skipped.sum())
        counts["false_rehit"] += int(rehit.sum())
    return counts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=["sphere1", "bunny", "skull"])
    parser.add_argument("--light-res", default="256,512,1024")
    parser.add_argument("--photon-res", type=int, default=256)
    parser.add_argument("--rules", default="old,new",
                        help="comma-separated: old, new, id, facing (start rules), SLOPE:FLOOR:MAX (texel footprints)")
    args = parser.parse_args(argv)

    import numpy as np

    import volcaustics.reference  # noqa: F401  (libLLVM before drjit)
    from volcaustics.approx import ApproxParams, Renderer, trace
    from volcaustics.approx.light import LightFrustum
    from volcaustics.reference.oracle import Oracle
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.bounds import medium_bounds

    new_rule = dict(trace.START_OFFSET)
    rules = []
    for text in args.rules.split(","):
        if text in ("old", "new"):
            rules.append((text, OLD_RULE if text == "old" else new_rule))
        elif text in ("id", "facing"):
            rules.append((text, None))
        else:
            slope, floor, cap = (float(x) for x in text.split(":"))
            rules.append((text, {"START_SLOPE": slope, "START_FLOOR": floor, "START_MAX": cap}))
    print(f"photon_res {args.photon_res}, stochastic Fresnel, 6 steps; shares of segments leaving a surface")
    print(f"{'scene':8} {'light_res':>9} {'rule':13} {'segments':>9} {'skipped':>8} {'false re-hit':>12}")
    for name in args.scenes:
        scene = resolve_scene(name)
        oracle = Oracle(scene)
        for light_res in (int(x) for x in args.light_res.split(",")):
            frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
            texel_angle = 2.0 * frustum.tan_half / light_res
            for label, rule in rules:
                trace.START_OFFSET.clear()
                trace.START_OFFSET.update(rule or new_rule)
                renderer = Renderer(scene)
                params = ApproxParams(photon_res=args.photon_res, light_res=light_res, width=32, height=32, steps=6,
                                      fresnel="stochastic", start_rule="offset" if rule else label)
                frame = renderer.render(params=params)
                renderer.release()
                c = classify(frame.records, oracle, texel_angle, np.asarray(scene.light.position),
                             window_rule=None if rule else new_rule)
                n = max(c["segments"], 1)
                print(f"{name:8} {light_res:9d} {label:13} {c['segments']:9d} {100 * c['skipped'] / n:7.2f}% "
                      f"{100 * c['false_rehit'] / n:11.2f}%", flush=True)
    trace.START_OFFSET.clear()
    trace.START_OFFSET.update(new_rule)
    return 0


if __name__ == "__main__":
    sys.exit(main())
