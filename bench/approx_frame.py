"""Per-pass times of the approximation: paper settings and the quick preset.

    .venv/bin/python bench/approx_frame.py [SCENE] [--frames N]

Any preset by name (--presets quick,beams; beams at its own photon_res 256, not matched;
--photon-res, --width and --height set every preset's). The splat pass's shaded fragments are printed beside the cost.
Paper (Wang, Wang & Chen): 800×800, photon_res 1500, layers 4, steps 4,
iterations 30, peak_samples 8; intersection estimation ≈ 70% and splatting ≈ 23%
of a frame on their GPU. Each preset renders one warm-up frame (shader
compilation, which llvmpipe does lazily), then N timed frames; the median per
pass is printed. Shares are computed within one run.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="two_spheres")
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--presets", default="quick,paper")
    parser.add_argument("--photon-res", type=int, help="every preset at this photon_res (default: its own)")
    parser.add_argument("--width", type=int, help="every preset at this width (default: its own)")
    parser.add_argument("--height", type=int, help="every preset at this height (default: its own)")
    args = parser.parse_args(argv)

    from volcaustics.approx import Renderer
    from volcaustics.approx.cost import frame_cost
    from volcaustics.approx.params import PRESETS
    from volcaustics.scenes import resolve_scene

    scene = resolve_scene(args.scene)
    renderer = Renderer(scene)
    presets = PRESETS  # every preset by name (beams: its photon_res unmatched)
    print(f"scene {scene.name}; GL: {renderer.ctx.info['GL_RENDERER']}")
    for name in args.presets.split(","):
        params = presets[name]
        given = {"photon_res": args.photon_res, "width": args.width, "height": args.height}
        params = dataclasses.replace(params, **{k: v for k, v in given.items() if v})
        t0 = time.perf_counter()
        renderer.render(params=params, keep_records=False)
        warm = time.perf_counter() - t0
        frames = [renderer.render(params=params, keep_records=False) for _ in range(args.frames)]
        passes = [k for k in frames[0].timings if not k.startswith("trace_step")]
        med = {k: statistics.median(f.timings[k] for f in frames) for k in passes}
        frame = med["frame_wall"]
        print(f"\n[{name}] {params.width}x{params.height}, photon_res {params.photon_res}, layers {params.layers}, "
              f"steps {params.steps}, iterations {params.iterations}, peak_samples {params.peak_samples}, "
              f"light_res {params.light_res}; timing: {frames[0].timing_method}; "
              f"first frame (compiles shaders) {warm:.2f} s; median of {args.frames}:")
        for k in passes:
            print(f"  {k:<12} {med[k]:8.3f} s  {100 * med[k] / frame:5.1f}%")
        print(f"  intersection estimation (trace) {100 * med['trace'] / frame:.0f}% vs splatting "
              f"{100 * med['splat'] / frame:.0f}% of the frame (paper: 70% / 23%)")
        counted = renderer.render(params=params, keep_records=True)  # the cost: untimed
        records = counted.records
        cost, segments = frame_cost(records, params.resolved(scene), counted.work), sum(len(r) for r in records)
        print(f"  map reads {cost['map_reads'] / 1e6:.2f} M per frame, {cost['map_reads'] / max(segments, 1):.1f} "
              f"per segment ({segments:,} segments); emission reads {cost['emission_reads'] / 1e6:.2f} M, splats "
              f"{cost['splats'] / 1e6:.3f} M; frame cost {cost['total'] / 1e6:.2f} M; splat pass shaded "
              f"{cost['shaded_splat'] / 1e6:.2f} M fragments")
    renderer.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
