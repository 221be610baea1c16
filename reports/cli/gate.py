"""``volcaustics gate``: exit 1 when the approximation exceeds its budgets or regresses."""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import (
    UsageError,
    add_gate_inputs,
    add_measurement_flags,
    measurement_from_args,
    path_type,
    scene_list,
)
from volcaustics.reports.measuring.results.output_folders import check_output_file, check_output_set

if TYPE_CHECKING:
    import argparse

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("drjit", "mitsuba", "moderngl")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("gate", help="fail (exit 1) when the approximation exceeds its budgets or regresses against "
                                    "the baseline; exit 2 on bad input or missing data")
    add_gate_inputs(p, scenes="comma-separated budgeted scenes (default: all in the budgets)")
    p.add_argument("--update-baseline", dest="update_baseline", action="store_true",
                   help="accept this run's results as the baseline (written atomically), no regression test")
    p.add_argument("--junit", metavar="OUT.xml", help="also write a JUnit XML report")
    p.add_argument("--out", default="runs/gate", help="gate.json and failure images (default runs/gate)")
    p.add_argument("--render-references", dest="render_references", action="store_true",
                   help="render missing references (else a missing one is an error, exit 2)")
    p.add_argument("--animation", action="append", type=path_type, metavar="DIR",
                   help="also hold an animation that `volcaustics animate SCENE -o DIR` measured to the budgets' "
                        "[animation.SCENE] flicker limits (repeatable)")
    p.add_argument("--compare", action="append", metavar="NAME=DIR",
                   help="also hold another renderer that `volcaustics compare` measured (DIR: one such folder or a "
                        "folder of them) to the budgets' [compare.NAME.SCENE] limits (repeatable)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_measurement_flags(p, default="the budgets' [measurement] table, else {value}")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.reports.measuring.results.param_input import parse_overrides
    from volcaustics.reports.studies.compare.comparison_read import parse_named
    from volcaustics.reports.studies.gate.budgets import default_budgets_path, load_budgets
    from volcaustics.reports.studies.gate.gate_outputs import VERDICT, console_table
    from volcaustics.reports.studies.gate.gate_run import run_gate
    from volcaustics.reports.studies.gate.regression import BASELINE

    check_output_set(args.out, "--out", files=(VERDICT,), kind="gate")
    if args.junit is not None:
        check_output_file(args.junit, "--junit", ".xml")
    if args.update_baseline and not args.baseline:
        raise UsageError("--update-baseline", True, "needs --baseline DIR (where to write it)")
    if args.update_baseline:
        check_output_set(args.baseline, "--baseline", files=(BASELINE,))
    overrides = parse_overrides(args.set)
    budgets = load_budgets(args.budgets or default_budgets_path())
    result = run_gate(budgets, overrides=overrides, baseline_dir=args.baseline, update_baseline=args.update_baseline,
                      out_dir=args.out, scenes=scene_list(args.scenes, "--scenes"), seeds=args.seeds, seed=args.seed,
                      render_references=args.render_references, junit=args.junit,
                      animation_dirs=args.animation or (),
                      comparisons=[parse_named(text, "--compare") for text in args.compare or ()],
                      measurement=measurement_from_args(args, budgets["measurement"]), progress=not args.quiet)
    print(console_table(result.checks))
    failed = sum(not c.passed for c in result.checks)
    print(f"gate {'FAILED' if failed else 'passed'}: {failed} of {len(result.checks)} checks failed, "
          f"{result.measured} point(s) measured, {result.from_store} from the result store, "
          f"{result.seconds:.1f} s -> {args.out}/{VERDICT}" + (f", {args.junit}" if args.junit else "")
          + (f"; baseline written: {result.updated_baseline}" if result.updated_baseline else ""))
    return result.exit_code
