"""Frame time and map reads per search variant, one process.

    .venv/bin/python bench/variants.py [SCENE] [--frames 3] [--preset paper]
        [--variants bisection/offset,secant/offset,dda/offset,hiz/offset,bisection/offset/surface,...]

Each variant (search/start_rule[/crossing], other parameters at the preset) renders one
warm-up frame (shader compilation), then FRAMES timed frames, interleaved round
robin so that the machine's drift spreads over all variants; the median frame and
trace time are printed with the map reads per segment and per frame of one
untimed frame with records (cost that travels across hardware; llvmpipe wall time
says little about GPUs), and each time as a ratio to the first variant's.
"""

from __future__ import annotations

import argparse
import statistics
import sys

DEFAULT = ",".join(f"{s}/{r}" for r in ("offset", "id", "facing") for s in ("bisection", "secant", "dda", "hiz"))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="two_spheres")
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--variants", default=DEFAULT)
    args = parser.parse_args(argv)

    from volcaustics.approx import Renderer
    from volcaustics.approx.params import preset
    from volcaustics.scenes import resolve_scene

    scene = resolve_scene(args.scene)
    renderer = Renderer(scene)
    variants = [tuple(v.split("/")) for v in args.variants.split(",")]
    params = {v: preset(args.preset, **dict(zip(("search", "start_rule", "crossing"), v))) for v in variants}
    print(f"scene {scene.name}; preset {args.preset}; GL: {renderer.ctx.info['GL_RENDERER']}")
    for v in variants:
        renderer.render(params=params[v], keep_records=False)  # warm-up: compiles
    times = {v: [] for v in variants}
    for _ in range(args.frames):
        for v in variants:
            times[v].append(renderer.render(params=params[v], keep_records=False).timings)
    base = None
    print(f"{'variant':<26} {'frame s':>8} {'ratio':>6} {'trace s':>8} {'ratio':>6} {'reads/seg':>10} "
          f"{'M reads/frame':>14}")
    for v in variants:
        frame = statistics.median(t["frame_wall"] for t in times[v])
        trace = statistics.median(t["trace"] for t in times[v])
        records = renderer.render(params=params[v], keep_records=True).records
        reads, segments = sum(int(r["map_reads"].sum()) for r in records), sum(len(r) for r in records)
        base = base or (frame, trace)
        print(f"{'/'.join(v):<26} {frame:8.2f} {frame / base[0]:6.2f} {trace:8.2f} {trace / base[1]:6.2f} "
              f"{reads / max(segments, 1):10.1f} {reads / 1e6:14.1f}", flush=True)
    renderer.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
