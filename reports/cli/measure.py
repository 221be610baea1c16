"""``volcaustics measure SCENE -o DIR``: one experiment, its tables and summary."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

from volcaustics.experiment.result import EqualCost, Experiment, ModelTerm
from volcaustics.reports.cli.common import (
    add_measurement_flags,
    add_report_reference,
    debiased,
    known,
    measurement_from_args,
    num,
    report_settings,
)
from volcaustics.reports.measuring.results.output_folders import check_output_set
from volcaustics.reports.measuring.results.param_input import add_param_flags, params_from_args, preset_size_note

if TYPE_CHECKING:
    import argparse

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("drjit", "mitsuba", "moderngl")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("measure", help="one experiment on SCENE: approximation vs reference, exact replay, all "
                                       "metrics -> DIR/{segments,photons,images}.{parquet,csv}, decomposition.exr, "
                                       "summary.json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml scene file")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--seeds", type=int, default=4,
                   help="frames with seeds --seed … --seed + N − 1: the approximation's own noise needs N ≥ 2, "
                        "intervals N ≥ 4 (default 4)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_param_flags(p, default_preset="quick")
    add_report_reference(p)
    add_measurement_flags(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.experiment.point_summary import KIND as EXPERIMENT_KIND
    from volcaustics.reports.api import measured_point
    from volcaustics.reports.measuring.results.store import SUMMARY
    from volcaustics.reports.measuring.runner import results_store
    from volcaustics.reports.presenting.exports.measure_files import OUTPUT_FILES, write_experiment
    from volcaustics.scenes import resolve_scene

    check_output_set(args.output, "-o", files=OUTPUT_FILES, kind=EXPERIMENT_KIND)
    scene = resolve_scene(args.scene)
    measurement = measurement_from_args(args)  # a bad --exact-subphotons: before the cost match and the reference
    params = params_from_args(args)
    note = preset_size_note(args, params, scene)  # the size: the cost match keeps it
    if note:
        print(f"measure: {note}", file=sys.stderr)
    # through the runner and the store the report and the gate share: a point measured before is read back
    point = measured_point(args.scene, params, args.preset, args.seeds, reference=report_settings(args),
                           measurement=measurement, photon_res_given=args.photon_res is not None,
                           layers_given=args.layers is not None, progress=not args.quiet, resolved=scene)
    stored = os.path.join(results_store().point_dir(point.key), SUMMARY)  # one summary: the store's, copied
    paths = write_experiment(point, args.output, summary_file=stored)
    e = point.experiment  # read at the store's boundary: attributes from here
    how = f"{e.seconds:.1f} s" if point.measured else f"from the store ({point.key[:12]})"
    print(f"measure {scene.name}: {e.seeds} seed(s), {how} -> {paths['summary.json']}")
    print_experiment(e)
    return 0


def print_experiment(e: Experiment) -> None:
    """The console's account of an experiment: its frame and cost, equal cost, image
    metrics, the decomposition, the model term and its warnings."""
    reads, cost = e.map_reads, e.cost
    read_text = "" if reads is None else (f"{reads.per_frame / 1e6:.2f} M map reads ({reads.per_segment:.1f} per "
                                          f"segment), ")
    print(f"  frame {1000 * cost.measured_s:.0f} ms ({cost.timing_method}), {read_text}frame cost "
          f"{cost.counted / 1e6:.2f} M (map and emission reads + {cost.splats / 1e6:.3f} M splats)")
    _print_equal_cost(e.equal_cost)
    _print_images(e)
    _print_decomposition(e)
    _print_model(e.model)
    for warning in e.warnings:
        print(f"  warning: {warning}")


def _print_equal_cost(check: EqualCost | None) -> None:
    if check is None:
        return
    predicted = ", ".join(f"{ratio:.2f}x ({name})" for name, ratio in check.predicted_ratio.items())
    verdict = "at the paper's cost" if check.at_paper_cost else "NOT at the paper's cost"
    print(f"  cost against the paper configuration: predicted {predicted}; measured frame time "
          f"{check.measured_ratio:.2f}x ({1000 * check.measured_s:.0f} against {1000 * check.paper_s:.0f} ms, "
          f"{check.method}): {verdict}")


def _print_images(e: Experiment) -> None:
    for component in dict.fromkeys(m.component for m in e.images):
        relmse, ratio, flip = (e.metric(name, component) for name in ("relative_mse", "energy_ratio", "hdr_flip"))
        mean = debiased(known(relmse.debiased), low=known(relmse.ci_low), high=known(relmse.ci_high))
        frame = next((m.estimate for m in e.images if m.component == component and m.metric == "frame_relative_mse"),
                     None)
        one = "" if frame is None or known(frame.debiased) is None else (
            f"one frame {debiased(frame.debiased, se=known(frame.standard_error))}, ")
        print(f"  {component:<9} relative MSE debiased {mean}, {one}"
              f"energy ratio {num(known(ratio.value))}, HDR-FLIP per frame {num(known(flip.value))}")


def _print_model(model: ModelTerm | None) -> None:
    if model is None:
        return
    needed = ", ".join(f"{c} {n if n is not None else 'more'}" for c, n in model.orders_needed.items())
    print(f"  single-scattering model against {model.max_scatter} scattering orders (orders needed: {needed}): "
          f"energy left out, its own relative MSE, its part of the relative MSE against R_ms")
    for m in model.components:
        share, own, part = m.energy_share, m.relmse_own, m.relmse_part
        if share is None or own is None or part is None:
            print(f"    {m.component:<9} {m.note}")
            continue
        print(f"    {m.component:<9} {100 * share.value:6.2f}% ± {100 * share.standard_error:.2f}  "
              f"{debiased(known(own.debiased), se=known(own.standard_error))}  "
              f"{100 * part.value:+7.2f}% ± {100 * part.standard_error:.2f}")


def _print_decomposition(e: Experiment) -> None:
    print("  caustic error decomposed: energy share of the reference ± SE, part of the relative MSE ± SE")
    for row in e.decomposition:  # none: a gate point, which measure never runs
        if row.term == "noise":
            print(f"    {'noise':<13} ±{100 * row.energy_share_se:6.2f}%            {100 * row.relmse_part:6.2f}%")
            continue
        print(f"    {row.term:<13} {100 * row.energy_share:+7.2f}% ± {100 * row.energy_share_se:.2f}  "
              f"{100 * row.relmse_part:+7.2f}% ± {100 * row.relmse_part_se:.2f}")
