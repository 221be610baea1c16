"""`--preset best` at the paper configuration's cost, checked in time on this machine's GL
renderer: per scene, best's photon_res matched under every shipped weight set
(``reports.measuring.cost_match``), its predicted cost ratio under each set and its measured
frame time against the paper configuration's (median of alternating frames, one
renderer); then the paper's own configuration (800², photon_res 1500) split into its
passes, to set beside the paper's Table 1 (trace ≈ 70%, splatting ≈ 23%).

    .venv/bin/python bench/equal_time.py [SCENE ...] [--frames N] [--json FILE] [--no-paper]

SCENE: built-in names or scene files (default: every built-in and held-out scene). Runs
the code of the checkout it is started from; on a GPU (``bench/cost_model.py --write``
there first, so that its weight set is among those matched on) this is the check the
paper's claims are about.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile


def main(argv=None) -> int:
    from volcaustics.approx import Renderer
    from volcaustics.approx.context import shared_context
    from volcaustics.approx.cost import TIMED_PASSES
    from volcaustics.approx.params import PAPER, PRESETS, QUICK
    from volcaustics.reports.measuring.cost_match import CostMatcher, measured_time_ratio
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.catalogue import BUILTIN_NAMES, HELDOUT_NAMES, heldout_path

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*")
    parser.add_argument("--frames", type=int, default=9, help="timed frames of each configuration (median)")
    parser.add_argument("--json", help="write the rows to this file")
    parser.add_argument("--no-paper", action="store_true", help="skip the paper configuration's pass split")
    args = parser.parse_args(argv)
    scenes = args.scenes or [*BUILTIN_NAMES, *(heldout_path(n) for n in HELDOUT_NAMES)]
    renderer_name = shared_context().info["GL_RENDERER"]
    print(f"GL renderer: {renderer_name}\n")
    matcher = CostMatcher(tempfile.mkdtemp(prefix="volcaustics-equal-time-"))
    rows = []
    print("| scene | photon_res | predicted cost ratio per weight set | measured time ratio | paper ms | best ms |\n"
          "|---|---:|---|---:|---:|---:|", flush=True)
    try:
        for name in scenes:
            scene = resolve_scene(name)
            paper = QUICK.resolved(scene)
            target = matcher.cost(name, paper)
            best = matcher.match(name, PRESETS["best"], target).resolved(scene)
            own = matcher.cost(name, best)
            predicted = {k: own[k] / target[k] for k in target}
            time = measured_time_ratio(name, best, paper, frames=args.frames)
            rows.append({"scene": scene.name, "photon_res": best.photon_res, "predicted": predicted, "time": time,
                         "gl_renderer": renderer_name})
            print(f"| {scene.name} | {best.photon_res} | "
                  f"{', '.join(f'{k} {v:.3f}' for k, v in predicted.items())} | {time['ratio']:.3f} | "
                  f"{1000 * time['paper_s']:.1f} | {1000 * time['config_s']:.1f} |", flush=True)
    finally:
        matcher.release()
    if not args.no_paper:
        print("\nthe paper's configuration (800², photon_res 1500, 4 layers, 4 steps): pass shares of the frame\n\n"
              "| scene | frame ms | " + " | ".join(TIMED_PASSES) + " |\n|---|---:|" + "---:|" * len(TIMED_PASSES))
        for name in scenes:
            scene = resolve_scene(name)
            renderer = Renderer(scene)
            try:
                p = PAPER.resolved(scene)
                renderer.render(scene, p, keep_records=False)  # compiles
                timings = [renderer.render(scene, p, keep_records=False).timings for _ in range(args.frames)]
            finally:
                renderer.release()
            med = {k: statistics.median(t.get(k, 0.0) for t in timings) for k in ("frame_wall", *TIMED_PASSES)}
            rows.append({"scene": scene.name, "paper_configuration": med, "gl_renderer": renderer_name})
            print(f"| {scene.name} | {1000 * med['frame_wall']:.1f} | "
                  + " | ".join(f"{100 * med[k] / med['frame_wall']:.0f}%" for k in TIMED_PASSES) + " |", flush=True)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
