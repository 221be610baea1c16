"""``volcaustics measure SCENE -o DIR``: one experiment, its tables and summary."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import (
    add_measurement_flags,
    add_report_reference,
    debiased,
    measurement_from_args,
    num,
    report_settings,
)
from volcaustics.reports.measuring.results.output_folders import check_output_set
from volcaustics.reports.measuring.results.param_input import add_param_flags, params_from_args, preset_size_note

if TYPE_CHECKING:
    import argparse

    from volcaustics.reports.measuring.results.summaries import ExperimentSummary

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
    from volcaustics.reports.api import measured_point
    from volcaustics.reports.measuring.experiment.measure_outputs import OUTPUT_FILES, write_experiment
    from volcaustics.reports.measuring.experiment.point_summary import KIND as EXPERIMENT_KIND
    from volcaustics.reports.measuring.results.store import SUMMARY
    from volcaustics.reports.measuring.runner import results_store
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
    s = point.summary  # as stored: plain JSON data (NaN → None)
    how = f"{s['experiment_seconds']['total']:.1f} s" if point.measured else f"from the store ({point.key[:12]})"
    print(f"measure {scene.name}: {s['seeds']} seed(s), {how} -> {paths['summary.json']}")
    reads = s["map_reads"]
    print(f"  frame {1000 * s['approx_timings_s']['frame_wall']:.0f} ms ({s['timing_method']}), "
          f"{reads['per_frame'] / 1e6:.2f} M map reads ({reads['per_segment']:.1f} per segment), frame cost "
          f"{s['cost']['total'] / 1e6:.2f} M (map and emission reads + {s['cost']['splats'] / 1e6:.3f} M splats)")
    _print_equal_cost(s.get("equal_cost"))
    _print_images(s)
    _print_decomposition(s)
    _print_model(s)
    for warning in s["warnings"]:
        print(f"  warning: {warning}")
    return 0


def _print_equal_cost(check: dict | None) -> None:
    if check is None:
        return
    predicted = ", ".join(f"{ratio:.2f}x ({name})" for name, ratio in check["predicted_ratio"].items())
    t = check["measured_time"]
    verdict = "at the paper's cost" if check["at_paper_cost"] else "NOT at the paper's cost"
    print(f"  cost against the paper configuration: predicted {predicted}; measured frame time {t['ratio']:.2f}x "
          f"({1000 * t['config_s']:.0f} against {1000 * t['paper_s']:.0f} ms, {t['method']}): {verdict}")


def _print_images(s: ExperimentSummary) -> None:
    for component, m in s["images"].items():
        relmse, ratio, flip = m["relative_mse"], m["energy_ratio"], m["hdr_flip"]
        mean = debiased(relmse["debiased"], low=relmse["ci_low"], high=relmse["ci_high"])
        frame = m.get("frame_relative_mse") or {}
        one = "" if frame.get("debiased") is None else (
            f"one frame {debiased(frame['debiased'], se=frame.get('standard_error'))}, ")
        print(f"  {component:<9} relative MSE debiased {mean}, {one}"
              f"energy ratio {num(ratio['value'])}, HDR-FLIP per frame {num(flip['value'])}")


def _print_model(s: ExperimentSummary) -> None:
    model = s.get("model")
    if model is None:
        return
    needed = ", ".join(f"{c} {n if n is not None else 'more'}" for c, n in model["orders_needed"].items())
    print(f"  single-scattering model against {model['max_scatter']} scattering orders (orders needed: {needed}): "
          f"energy left out, its own relative MSE, its part of the relative MSE against R_ms")
    for component, m in model["components"].items():
        if "note" in m:
            print(f"    {component:<9} {m['note']}")
            continue
        share, own, part = m["energy_share"], m["relmse_own"], m["relmse_part"]
        print(f"    {component:<9} {100 * share['value']:6.2f}% ± {100 * share['standard_error']:.2f}  "
              f"{debiased(own['debiased'], se=own['standard_error'])}  "
              f"{100 * part['value']:+7.2f}% ± {100 * part['standard_error']:.2f}")


def _print_decomposition(s: ExperimentSummary) -> None:
    print("  caustic error decomposed: energy share of the reference ± SE, part of the relative MSE ± SE")
    for row in (s["decomposition"] or {}).get("rows", []):  # None: a gate point, which measure never runs
        if row["term"] == "noise":
            print(f"    {'noise':<13} ±{100 * row['energy_sigma']:6.2f}%            {100 * row['relmse']:6.2f}%")
            continue
        print(f"    {row['term']:<13} {100 * row['energy_share']:+7.2f}% ± {100 * row['energy_share_se']:.2f}  "
              f"{100 * row['relmse_part']:+7.2f}% ± {100 * row['relmse_part_se']:.2f}")
