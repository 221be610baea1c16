"""``volcaustics report``: the accuracy report (one HTML page + summary.json)."""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from volcaustics.reports.cli.common import (
    add_gate_inputs,
    add_measurement_flags,
    add_report_reference,
    debiased,
    known,
    measurement_from_args,
    num,
    path_type,
    pct,
    report_settings,
    scene_list,
)
from volcaustics.reports.measuring.results.output_folders import check_output_set
from volcaustics.reports.studies.registry import reported

if TYPE_CHECKING:
    import argparse

    from volcaustics.reports.studies.study import ReportInput

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("drjit", "mitsuba", "moderngl")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("report", help="the main job: the accuracy report (one HTML page + summary.json) of the "
                                      "approximation against ground truth, with the gate's verdicts")
    p.add_argument("--out", default="runs/report", help="output folder (default runs/report)")
    add_gate_inputs(p, scenes="comma-separated SCENE arguments (default: every built-in)")
    for study in reported():  # each study's output the report takes (reports.studies.registry)
        r = cast("ReportInput", study.report)
        p.add_argument(r.option, action="append" if r.repeatable else "store", type=path_type if r.path else str,
                       metavar=r.metavar, help=r.help)
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    add_report_reference(p)
    add_measurement_flags(p, default="the budgets' [measurement] table, else {value}")
    p.set_defaults(func=run)


def study_values(args: argparse.Namespace) -> dict:
    """Study name → the values its report option was given (none: left out)."""
    out = {}
    for study in reported():
        value = getattr(args, cast("ReportInput", study.report).option.lstrip("-").replace("-", "_"))
        if value:
            out[study.name] = value if isinstance(value, list) else [value]
    return out


def run(args: argparse.Namespace) -> int:
    from volcaustics.reports.measuring.results.param_input import parse_overrides
    from volcaustics.reports.presenting.page.report_summary import OUTPUT_FILES
    from volcaustics.reports.presenting.report.report_run import run_report
    from volcaustics.reports.studies.gate.budgets import default_budgets_path, load_budgets
    from volcaustics.scenes import BUILTIN_NAMES

    check_output_set(args.out, "--out", files=OUTPUT_FILES, folders=("figures",))
    names = scene_list(args.scenes, "--scenes")
    budgets = load_budgets(args.budgets or default_budgets_path())
    document = run_report(args.out, names if names is not None else list(BUILTIN_NAMES),
                          overrides=parse_overrides(args.set), seeds=args.seeds, seed=args.seed,
                          reference_settings=report_settings(args), budgets=budgets, baseline_dir=args.baseline,
                          measurement=measurement_from_args(args, budgets["measurement"]),
                          studies=study_values(args), progress=not args.quiet)
    for page in document.scenes:
        caustic, combined = page.components["caustic"], page.components["combined"]
        failed = [ch.name for ch in page.gate.failed]
        note = page.gate.note
        gate = ("FAIL " + ", ".join(failed)) if failed else ("pass" if page.gate.checks else
                                                             f"not checked ({note})" if note else "not checked")
        print(f"{page.scene:<12} caustic relMSE {debiased(known(caustic.estimate('relative_mse').debiased))}, "
              f"energy {num(known(caustic.estimate('energy_ratio').value))}; combined relMSE "
              f"{debiased(known(combined.estimate('relative_mse').debiased))}; gate {gate}")
    verdict = "passed" if document.gate.passed else "FAILED" if document.gate.failed else "not checked"
    for row in document.animations:
        m = row["metrics"][row["seed_modes"][0]]["caustic"]
        print(f"{row['scene']:<12} over time: caustic flicker {pct(m['flicker'])} ({row['seed_modes'][0]} seed), "
              f"{len(row['frames'])} frames" + (" (measured with other code: rerun animate)" if row["stale"] else ""))
    for row in document.comparisons:
        m = row["images"].get("caustic") or row["images"]["combined"]
        print(f"{row['scene']:<12} {row['renderer']}: {'caustic' if 'caustic' in row['images'] else 'combined'} "
              f"relMSE {debiased(m['relative_mse'].get('debiased'))}, energy {num(m['energy_ratio'].get('value'))}")
    print(f"report: {len(document.scenes)} scenes, gate {verdict} ({document.gate.failed} of {document.gate.checks} "
          f"checks failed), {document.seconds['total']:.0f} s -> {args.out}/index.html")
    return 0
