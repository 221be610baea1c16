"""Display frames per second: ``Renderer.draw`` frame after frame, beside the measured frame.

    .venv/bin/python bench/realtime.py [SCENE] [--preset NAME] [--size WxH] [--frames N] [--photon-res N]
    .venv/bin/python bench/realtime.py [SCENE] --paper [--frames N]

One configuration (--preset, default quick, at --size, default the preset's; best and beams at
their photon_res matched to the quick preset's cost at that size, as the commands do:
``reports.measuring.cost_match.with_auto_values``), or with --paper the paper's configuration (the
preset paper: 800×800, photon_res 1500, layers 4, steps 4, light_res 1024, the table's
defaults) and then best and beams at 800×800 with photon_res matched to that paper frame's
cost (``CostMatcher.match_to``, memo in the cache's cost_match folder), one block each and a
summary table. Each configuration: 2 warm-up display frames (llvmpipe compiles shaders
lazily) and a ``finish``, then N display frames issued back to back and one ``finish``;
printed: frames per second (wall clock from the first timed draw to after the finish), host
CPU per frame, frames in flight at the last draw, GL objects made per steady frame, GPU time
per pass from the renderer's late timer where timer queries work (median over the frames
collected; trace = every trace_step; shares beside the paper's 70% / 23%), and the measured
frame (``Renderer.render``, no records: a ``finish`` or a query read per pass, then reads)
on the same settings, median of 3, for the display frame's saving.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from volcaustics.approx import Renderer
    from volcaustics.approx.params import ApproxParams
    from volcaustics.scenes.model import Scene

WARMUP = 2  # display frames before timing: the first compiles every program
MEASURED = 3  # measured frames (Renderer.render) whose median is the comparison
PAPER_SIZE = 800  # the paper's image, 800×800 (Wang, Wang & Chen, Table 1)
PAPER_SHARES = {"trace": 0.70, "splat": 0.23}  # intersection estimation and splatting, of their frame


def parse_size(text: str) -> tuple[int, int]:
    """``WxH`` (pixels) as (width, height); ArgumentTypeError otherwise."""
    width, sep, height = text.lower().partition("x")
    if not sep or not width.isdigit() or not height.isdigit() or int(width) < 1 or int(height) < 1:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WxH in pixels, e.g. 256x256")
    return int(width), int(height)


def matched_to(scene_name: str, params: ApproxParams, paper: ApproxParams) -> ApproxParams:
    """``params`` with the photon_res at which its frame costs at most ``paper``'s (resolved
    parameters) on the scene, by the project's matching (``reports.measuring.cost_match.CostMatcher``),
    remembered where ``with_auto_values`` remembers its matches."""
    from volcaustics.infra.storage import cache_path
    from volcaustics.reports.measuring.cost_match import CostMatcher

    matcher = CostMatcher(cache_path("cost_match"))
    try:
        matched = matcher.match_to(scene_name, params, paper)
        matcher.save()
    finally:
        matcher.release()
    return matched


def configurations(args: argparse.Namespace) -> list[tuple[str, ApproxParams]]:
    """(name, parameters) of each configuration to run, photon_res already matched."""
    from volcaustics.approx.params import preset
    from volcaustics.reports.measuring.cost_match import with_auto_values
    from volcaustics.scenes import resolve_scene

    if not args.paper:
        size = {"width": args.size[0], "height": args.size[1]} if args.size else {}
        given = {"photon_res": args.photon_res} if args.photon_res else {}
        params = preset(args.preset, **size, **given)
        return [(args.preset, with_auto_values(args.scene, params, args.preset, bool(given)))]
    paper = preset("paper", width=PAPER_SIZE, height=PAPER_SIZE)
    target = paper.resolved(resolve_scene(args.scene))
    out = [("paper", paper)]
    for name in ("best", "beams"):
        t0 = time.perf_counter()
        matched = matched_to(args.scene, preset(name, width=PAPER_SIZE, height=PAPER_SIZE), target)
        print(f"{name}: photon_res {matched.photon_res} matched to the paper frame's cost "
              f"({time.perf_counter() - t0:.1f} s, memo included)", flush=True)
        out.append((name, matched))
    return out


def pass_medians(collected: list) -> dict[str, float]:
    """Median GPU seconds per pass over the late timer's collected frames ({pass: s} each),
    the trace steps summed into ``trace`` and every pass into ``frame``."""
    frames = []
    for _, times in collected:
        merged: dict[str, float] = {"trace": 0.0}
        for name, seconds in times.items():
            key = "trace" if name.startswith("trace_step") else name
            merged[key] = merged.get(key, 0.0) + seconds
        merged["frame"] = sum(times.values())
        frames.append(merged)
    names = sorted({name for frame in frames for name in frame})
    return {name: statistics.median(frame.get(name, 0.0) for frame in frames) for name in names}


def run_configuration(renderer: Renderer, scene: Scene, params: ApproxParams, frames: int) -> dict:
    """Time ``frames`` display frames and :data:`MEASURED` measured frames of ``params``;
    every figure the block prints (seconds, counts)."""
    ctx, late = renderer.ctx, renderer.late_timer
    for _ in range(WARMUP):
        renderer.draw(scene, params)
    ctx.finish()
    made, first = renderer.pool.made, late.frames if late is not None else 0
    wall0, cpu0, thread0 = time.perf_counter(), time.process_time(), time.thread_time()
    for _ in range(frames):
        renderer.draw(scene, params)
    cpu, thread = time.process_time() - cpu0, time.thread_time() - thread0
    in_flight = late.in_flight if late is not None else None
    ctx.finish()
    wall = time.perf_counter() - wall0
    gpu: dict[str, float] = {}
    if late is not None:
        late.collect()  # after the finish every frame's timestamps are there: none waited for
        timed = [(n, t) for n, t in late.collected if n >= first]
        gpu = pass_medians(timed) if timed and late.supported else {}
    measured = [renderer.render(scene, params, keep_records=False) for _ in range(MEASURED)]
    return {"wall": wall, "fps": frames / wall, "cpu": cpu / frames, "thread": thread / frames,
            "in_flight": in_flight, "dropped": late.dropped if late is not None else None,
            "made": (renderer.pool.made - made) / frames, "gpu": gpu,
            "measured": statistics.median(f.timings["frame_wall"] for f in measured),
            "measured_method": measured[0].timing_method, "method": late.method if late is not None else "none"}


def print_block(name: str, p: ApproxParams, r: dict, frames: int, gl_renderer: str) -> None:
    display = r["wall"] / frames
    print(f"\n[{name}] {p.width}x{p.height}, photon_res {p.photon_res}, light_res {p.light_res}, layers {p.layers}, "
          f"steps {p.steps}, splat {p.splat}, fresnel {p.fresnel}, fresnel_splits {p.fresnel_splits}, "
          f"fog_steps {p.fog_steps}; {frames} display frames after {WARMUP} warm-up")
    print(f"  frames per second      {r['fps']:8.2f}  ({1000 * display:.1f} ms per display frame, wall clock to "
          f"after one finish)")
    print(f"  host CPU per frame     {1000 * r['thread']:8.1f} ms  main thread (time.thread_time: the issuing "
          f"thread, the figure used); whole process {1000 * r['cpu']:.1f} ms (time.process_time: on llvmpipe "
          f"it also counts the driver's rasterizer and compute threads, i.e. the 'GPU' work)")
    flight = "none (no timer queries)" if r["in_flight"] is None else f"{r['in_flight']} (dropped {r['dropped']})"
    print(f"  frames in flight       {flight}")
    print(f"  GL objects made per steady frame {r['made']:g}")
    if r["gpu"]:
        frame = r["gpu"]["frame"]
        print(f"  per-pass GPU time (median of the collected frames; {r['method']}):")
        for key, seconds in r["gpu"].items():
            if key != "frame":
                print(f"    {key:<10} {1000 * seconds:8.2f} ms  {100 * seconds / frame:5.1f}%")
        print(f"    {'frame':<10} {1000 * frame:8.2f} ms  (sum of the passes)")
        shares = " / ".join(f"{100 * r['gpu'].get(k, 0.0) / frame:.0f}%" for k in PAPER_SHARES)
        print(f"  trace / splat          {shares} of the GPU frame (paper: 70% / 23%)")
    else:
        print(f"  per-pass GPU time: not measured ({gl_renderer}: timer queries unsupported; method {r['method']})")
    print(f"  timing method          display frames: wall clock + late timer ({r['method']}); measured frame: "
          f"{r['measured_method']}")
    print(f"  measured frame         {1000 * r['measured']:8.1f} ms (Renderer.render, no records, median of "
          f"{MEASURED}); display frame {display / r['measured']:.2f}x its time "
          f"({r['measured'] / display:.2f}x as many frames per second)")


def print_summary(rows: list[tuple[str, ApproxParams, dict]], frames: int) -> None:
    paper_gpu = rows[0][2]["gpu"].get("frame")
    print("\n| config | photon_res | fps | display ms/frame | measured ms/frame | host CPU ms/frame | "
          "GPU ms/frame | GPU vs paper |\n|---|---:|---:|---:|---:|---:|---:|---:|")
    for name, p, r in rows:
        gpu = r["gpu"].get("frame")
        ratio = f"{gpu / paper_gpu:.2f}x" if gpu and paper_gpu else "-"
        print(f"| {name} | {p.photon_res} | {r['fps']:.2f} | {1000 * r['wall'] / frames:.1f} | "
              f"{1000 * r['measured']:.1f} | {1000 * r['thread']:.1f} | "
              f"{f'{1000 * gpu:.2f}' if gpu else 'not measured'} | {ratio} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="sphere1")
    parser.add_argument("--preset", default="quick", help="the configuration (default quick)")
    parser.add_argument("--size", type=parse_size, help="WxH in pixels (default: the preset's)")
    parser.add_argument("--photon-res", type=int, help="photon_res (default: the preset's, or matched)")
    parser.add_argument("--frames", type=int, default=5, help="timed display frames (default 5)")
    parser.add_argument("--paper", action="store_true",
                        help="the paper's configuration at 800x800, then best and beams matched to its cost")
    args = parser.parse_args(argv)
    if args.paper and (args.size or args.photon_res or args.preset != "quick"):
        parser.error("--paper sets the configurations itself: no --preset, --size or --photon-res with it")
    if args.frames < 1:
        parser.error("--frames must be >= 1")

    from volcaustics.approx import Renderer
    from volcaustics.scenes import resolve_scene

    scene = resolve_scene(args.scene)
    configs = configurations(args)
    renderer = Renderer(scene)
    gl_renderer = renderer.ctx.info["GL_RENDERER"]
    print(f"scene {scene.name}; GL renderer: {gl_renderer}", flush=True)
    rows = []
    try:
        for name, params in configs:
            p = params.resolved(scene)
            result = run_configuration(renderer, scene, p, args.frames)
            print_block(name, p, result, args.frames, gl_renderer)
            sys.stdout.flush()
            rows.append((name, p, result))
    finally:
        renderer.release()
    if len(rows) > 1:
        print_summary(rows, args.frames)
    return 0


if __name__ == "__main__":
    sys.exit(main())
