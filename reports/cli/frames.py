"""``volcaustics frames [SCENE ...] -o DIR``: the paper's configuration against
``--preset best``, one frame and the mean, without and with OIDN, per scene
(``reports.studies.best.frame_check``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import UsageError, debiased
from volcaustics.reports.measuring.results.output_folders import check_output_set
from volcaustics.reports.studies.sweep.study_limits import FRAME_CHECK_SEEDS as SEEDS

if TYPE_CHECKING:
    import argparse

NATIVE = ("drjit", "mitsuba", "moderngl")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("frames", help="the paper's configuration against --preset best on every built-in and "
                                      "held-out scene: one frame's caustic error and the mean's, without and "
                                      "with OIDN -> DIR/frames.parquet, frames.json")
    p.add_argument("scenes", nargs="*", metavar="SCENE",
                   help="built-in names or scene files (default: every built-in and scenes/heldout/*.toml)")
    p.add_argument("-o", "--output", default="runs/frames", metavar="DIR", help="output folder (default runs/frames)")
    p.add_argument("--seeds", type=int, default=SEEDS, help=f"frames per point (default {SEEDS})")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.reports.api import frames
    from volcaustics.reports.studies.best.frame_check import FRAMES_FILE, GROUPS, KIND, MANIFEST, POINTS

    check_output_set(args.output, "-o", files=(FRAMES_FILE, MANIFEST), folders=(POINTS,), kind=KIND)
    if isinstance(args.seeds, bool) or not 2 <= args.seeds <= 64:
        raise UsageError("--seeds", args.seeds, "expected an integer in [2, 64] (one frame's SE needs 2)")
    check = frames(args.output, scenes=args.scenes or None, seeds=args.seeds, progress=not args.quiet)
    table, v = check.table, check.verdict
    label = {"builtin": "", "media": " (medium)", "heldout": " (held out)", "yours": " (yours)"}
    for _, r in table.iterrows():
        print(f"  {r['scene']:<14}{label[r['group']]:<11} {r['config']:<6} {r['denoise']:<5} "
              f"cost {r['cost_ratio']:.3f}x predicted, time {r['time_ratio']:.2f}x measured, "
              f"one frame {debiased(r['frame_relmse'], se=r['frame_relmse_se'])} ({r['frame_ratio']:.2f}x), "
              f"mean {debiased(r['relmse_debiased'], se=r['relmse_se'])} ({r['relmse_ratio']:.2f}x)")
    names = {"builtin": "on the built-ins", "media": "in the media scenes", "heldout": "held out",
             "yours": "on your scenes"}
    worst = ", ".join(f"{v[f'none_{g}_worst_frame_ratio']:.2f}x {names[g]}" for g in GROUPS
                      if f"none_{g}_worst_frame_ratio" in v)
    print(f"frames: best's worst one-frame ratio {worst} (goal {v['goal']:g}x): "
          f"{'met' if v['met'] else 'not met'} -> {args.output}/{FRAMES_FILE}")
    return 0
