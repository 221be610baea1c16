"""``volcaustics animate SCENE -o DIR``: a scene's [animation] measured over time."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import UsageError, add_report_reference, pct, report_settings
from volcaustics.reports.measuring.results.output_folders import check_output_set
from volcaustics.reports.measuring.results.param_input import add_param_flags, params_from_args
from volcaustics.reports.studies.animate.animation_settings import (
    ANIMATION_REFERENCE,
    ANIMATION_SIZE,
    DEFAULT_CHAINS,
    SEED_MODES,
    animation_size,
    chain_seed,
    frame_list,
)

if TYPE_CHECKING:
    import argparse

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("drjit", "mitsuba", "moderngl")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("animate", help="SCENE's [animation] over time: approximation and reference per frame -> "
                                       "DIR/{frames,temporal}.{parquet,csv}, animation.mp4/.webp, timeseries.png, "
                                       "summary.json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or .toml file with an [animation] table "
                                                  "(built-ins: bunny, refocus, two_spheres)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--frames", metavar="N|A:B[:STEP]",
                   help="render N frames evenly spaced over the animation, or a slice of its frames (default all)")
    seeds = p.add_mutually_exclusive_group()
    seeds.add_argument("--seed-per-frame", dest="modes", action="store_const", const=("per-frame",),
                       help="only the approximation with a new seed every frame")
    seeds.add_argument("--fixed-seed", dest="modes", action="store_const", const=("fixed",),
                       help="only the approximation with one seed for the whole animation")
    p.add_argument("--chains", type=int, default=DEFAULT_CHAINS,
                   help="independent sequences per seed mode, with seeds --seed, --seed + 1, ...: the "
                        f"approximation's own noise needs 2 (default {DEFAULT_CHAINS})")
    add_report_reference(p, ANIMATION_REFERENCE, target=None, per=" per frame")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_param_flags(p, default_preset="quick")
    p.set_defaults(func=run, modes=SEED_MODES)
    p.epilog = (f"Without --width/--height frames are {ANIMATION_SIZE} pixels on the longer side. Both seed modes "
                "are measured unless one is chosen; the video shows the first.")


def run(args: argparse.Namespace) -> int:
    from volcaustics.experiment.point_checks import checked_settings
    from volcaustics.reports.measuring import runner
    from volcaustics.reports.measuring.cost_match import with_auto_values
    from volcaustics.reports.studies.animate.animation_frames import WORK
    from volcaustics.reports.studies.animate.animation_measure import run_animate
    from volcaustics.reports.studies.animate.animation_read import KIND
    from volcaustics.reports.studies.animate.animation_write import output_files
    from volcaustics.scenes import resolve_scene

    check_output_set(args.output, "-o", files=output_files(), folders=(WORK,), kind=KIND)
    scene = resolve_scene(args.scene)
    if scene.animation is None:
        raise UsageError("SCENE", args.scene, "has no [animation] table: add one (docs/scene-format.md, "
                                              "'Animated scenes') or name a built-in animation: bunny, refocus, "
                                              "two_spheres")
    if isinstance(args.chains, bool) or not 1 <= args.chains <= 64:
        raise UsageError("--chains", args.chains, "expected an integer in [1, 64]")
    try:
        frames = frame_list(args.frames, scene.animation.frames)
    except ValueError as exc:
        raise UsageError("--frames", args.frames, str(exc).split(": ", 1)[1]) from None
    params = params_from_args(args)
    if params.temporal == "ema" and "per-frame" not in args.modes:
        raise UsageError("--fixed-seed", True, "temporal = ema averages frames with a seed each (the per-frame "
                                               "seed mode): give --seed-per-frame or neither")
    if args.width is None and args.height is None:
        width, height = animation_size(scene.camera)
        params = dataclasses.replace(params, width=width, height=height)
    params = with_auto_values(args.scene, params, args.preset, args.photon_res is not None,  # at the frames' size
                              layers_given=args.layers is not None)
    base = params.seed
    top_seed = max(chain_seed(m, base, c, args.chains, t) for t in frames for m in args.modes
                   for c in range(args.chains))
    params, _ = checked_settings(scene, dataclasses.replace(params, seed=top_seed), 1)  # fits and seeds: before work
    params = dataclasses.replace(params, seed=base)
    settings = report_settings(args)
    summary, paths, measured = run_animate(scene, params, frames=frames, modes=tuple(args.modes), chains=args.chains,
                                           reference_settings=settings, out_dir=args.output,
                                           store=runner.results_store(), progress=not args.quiet)
    _print(summary, paths, measured)
    return 0


def _print(summary: dict, paths: dict, measured: bool) -> None:
    from volcaustics.reports.studies.animate.animation_read import MeasuredAnimation

    a = MeasuredAnimation.from_summary(summary)
    sec = a.seconds
    source = f"{sec['total']:.1f} s" if measured else f"from the result store (measured in {sec['total']:.1f} s)"
    print(f"animate {a.scene}: {len(a.frames)} frames x {len(a.seed_modes)} seed mode(s) x {a.chains} "
          f"chain(s), {source} -> {paths['summary.json']}")
    print(f"  per frame: approximation {1000 * sec['approx_frame_median']:.0f} ms, reference "
          f"{sec['reference_frame_median']:.1f} s ({sec['references_cached']} of {len(a.frames)} from the cache)")
    print(f"  note: {(a.perceptual_video_metric or {}).get('reason')}")
    for mode, components in a.metrics.items():
        for component in ("caustic", "combined"):
            m = components[component]
            mean, worst = m.series["relative_mse"]
            print(f"  {mode:<9} {component:<8} flicker {pct(m.flicker)} ± {pct(m.flicker_se).strip()} "
                  f"(systematic {pct(m.flicker_systematic).strip()}), relative MSE per frame mean "
                  f"{pct(mean).strip()} worst {pct(worst).strip()}, "
                  f"energy jitter RMS {m.energy_jitter_rms:.4f}, lag {m.lag_frames:g} frame(s)")
