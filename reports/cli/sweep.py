"""``volcaustics sweep``: a grid of experiments, resumable, on local processes or Dask."""

from __future__ import annotations

import dataclasses
import sys
from typing import TYPE_CHECKING

from volcaustics.approx.params import PARAMS, PRESETS
from volcaustics.experiment.measurement import MEASUREMENT_KEYS
from volcaustics.reports.cli.common import UsageError, add_measurement_flags, measurement_from_args
from volcaustics.reports.measuring.pools.dask_address import WORKER_WAIT, check_reachable, parse_dask
from volcaustics.reports.measuring.results.output_folders import check_output_set
from volcaustics.reports.studies.sweep.study_limits import CRITERIA, MAX_POINTS

if TYPE_CHECKING:
    import argparse

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("drjit", "mitsuba", "moderngl")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    names = ", ".join(p.name for p in PARAMS)
    p = sub.add_parser("sweep", help="a grid of experiments over approximation parameters, resumable, on local "
                                     "processes or Dask -> DIR (store, tables, figures)")
    p.add_argument("spec", nargs="?", metavar="SPEC.toml", help="the sweep as a TOML file (else the options below)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="the store folder (resumed when it exists)")
    p.add_argument("--scenes", help="comma-separated SCENE arguments (default: every built-in; with a SPEC file or "
                                    "--best, in place of its scenes)")
    p.add_argument("--vary", action="append", metavar="NAME=V1,V2,...",
                   help=f"a grid axis (repeatable); NAME one of {names}, or a scene field: a dotted path into "
                        f"the scene file such as medium.sigma_s, light.intensity, specular.0.ior")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="a fixed parameter or scene field (repeatable)")
    p.add_argument("--preset", choices=tuple(PRESETS), help="the parameters not named (default quick; a SPEC "
                                                            "file says its own)")
    p.add_argument("--seeds", type=int, help="seeds per point (default 1; a SPEC file says its own)")
    p.add_argument("--workers", type=int, help="local worker processes (default: the core count)")
    p.add_argument("--dask", metavar="tcp://HOST:PORT|local:N",
                   help="run on Dask distributed: a running scheduler, or a LocalCluster of N process workers")
    p.add_argument("--dask-wait", type=float, metavar="SECONDS",
                   help="with --dask tcp://…: how long the scheduler may take to have a worker before the sweep "
                        "exits 2 (default 60)")
    p.add_argument("--yes", action="store_true",
                   help=f"run a grid of more than {MAX_POINTS:,} points (refused without it: a typo more often than a "
                        f"plan)")
    p.add_argument("--best", action="store_true",
                   help="the best-configuration search instead of a grid: SPEC (default "
                        "reports/studies/best/best.toml) states its coarse and refine axes; every configuration "
                        "at the paper's frame cost (docs/concepts/equal-cost.md)")
    p.add_argument("--criterion", choices=tuple(CRITERIA),
                   help="what --best ranks by (default frame): frame (one frame's caustic relative MSE less the "
                        "reference's floor: bias and the frame's own noise, what a viewer sees) or bias (the seeds' "
                        "mean's, debiased)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_measurement_flags(p, default="the SPEC file's [measurement] table, else {value}")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.reference.render.sources import BatchError
    from volcaustics.reports.studies.sweep.sweep_run import OUTPUT_FILES, OUTPUT_FOLDERS

    check_output_set(args.output, "-o", files=OUTPUT_FILES, folders=OUTPUT_FOLDERS, kind="sweep")
    if args.spec and (args.vary or args.set or args.preset or args.seeds is not None):
        raise UsageError("SPEC.toml", args.spec, "give the grid in the file or on the command line, not both "
                                                 "(--vary, --set, --preset and --seeds belong to the file; --scenes "
                                                 "replaces its scenes)")
    if args.criterion is not None and not args.best:
        raise UsageError("--criterion", args.criterion, "ranks the best search's configurations: give it with --best")
    if args.workers is not None and args.dask:
        raise UsageError("--workers", args.workers, "is for local worker processes; with --dask the scheduler's "
                                                    "workers run the points (local:N says how many)")
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers", args.workers, "expected at least 1 worker process")
    if args.dask:
        try:
            parse_dask(args.dask)
        except ValueError as exc:
            raise UsageError("--dask", args.dask, str(exc).split(": ", 1)[-1]) from None
        if args.dask_wait is not None and not 0 <= args.dask_wait <= 3600:
            raise UsageError("--dask-wait", args.dask_wait, "expected seconds in [0, 3600]")
        check_reachable(args.dask, workers_wait=WORKER_WAIT if args.dask_wait is None else args.dask_wait)
    measurement_from_args(args)  # a bad value: exit 2 naming the flag, before anything
    try:
        return _run_best(args) if args.best else _run_grid(args)
    except BatchError as exc:  # a worker died under a reference's batch (a point's failure is reported per point)
        print(f"volcaustics: error: {exc}; the stored points are kept: run the sweep again", file=sys.stderr)
        return 1


def _run_grid(args) -> int:
    from volcaustics.reports.measuring.pools.executors import default_workers
    from volcaustics.reports.studies.sweep.sweep_run import run_sweep
    from volcaustics.reports.studies.sweep.sweep_spec import spec_from_args, spec_from_toml

    max_points = None if args.yes else MAX_POINTS
    if args.spec:
        spec = spec_from_toml(args.spec, max_points, _scenes(args))
    else:
        spec = spec_from_args(args.scenes, args.vary, args.set, preset=args.preset or "quick",
                              seeds=1 if args.seeds is None else args.seeds, max_points=max_points)
    result = run_sweep(_measured(spec, args), args.output, workers=args.workers or default_workers(), dask=args.dask,
                       progress=not args.quiet)
    print(f"sweep: {result.total} points: {result.done_before} already in the store, {result.computed} computed, "
          f"{len(result.failed)} failed, {result.seconds:.1f} s -> {args.output}/")
    _print_suffice(result.tables.get("suffice"))
    _print_variants(result.tables.get("variants_best"))
    _print_crossing(result.tables.get("model_crossing"))
    for failure in result.failed:
        print(f"  failed: {failure['key'][:12]}: {failure['error']}", file=sys.stderr)
    return 1 if result.failed else 0


def _run_best(args) -> int:
    import pandas as pd

    from volcaustics.reports.measuring.pools.executors import default_workers
    from volcaustics.reports.studies.best.best_search import run_best
    from volcaustics.reports.studies.best.best_spec import BEST_SPEC, load_best_spec

    if args.vary or args.set or args.preset or args.seeds is not None:
        raise UsageError("--best", "", "the search's axes, preset and seeds belong to its SPEC file; only --scenes "
                                       "may narrow it")
    spec = _measured(load_best_spec(args.spec or BEST_SPEC, _scenes(args)), args)
    best = run_best(spec, args.output, workers=args.workers or default_workers(), dask=args.dask,
                    progress=not args.quiet, criterion=args.criterion or "frame")
    table, adopted, result, failed = best.table, best.adopted, best.verdict, best.failed
    if table.empty:
        for failure in failed:
            print(f"  failed: {failure['key'][:12]}: {failure['error']}", file=sys.stderr)
        print(f"sweep --best: every one of its {len(best.keys)} points failed (above): nothing to rank, nothing "
              f"written", file=sys.stderr)
        return 1
    print(f"best configuration: {len(best.keys)} points, {len(failed)} failed, {best.seconds:.1f} s -> "
          f"{args.output}/best.parquet")
    for _, r in table[table["role"] != ""].iterrows():
        se = "" if pd.isna(r["caustic_relmse_se"]) else f" ± {100 * r['caustic_relmse_se']:.2f}"
        print(f"  {r['scene']:<12} {r['role']:<20} {r['config']}: photon_res {r['photon_res']}, cost "
              f"{r['cost_ratio']:.3f}x, caustic relMSE {100 * r['caustic_relmse_debiased']:.2f}%{se} "
              f"({r['relmse_ratio']:.2f}x the paper's); one frame {100 * r['frame_relmse']:.2f}% "
              f"({r['frame_ratio']:.2f}x)")
    if adopted is not None:
        print(f"adopted for every scene by {args.criterion or 'frame'}: {adopted}; worst ratio "
              f"{result['worst_ratio']:.2f}x "
              f"against the goal {result['goal']:g}x: {'met' if result['met'] else 'not met'} (one frame: worst "
              f"{result.get('worst_frame_ratio', float('nan')):.2f}x; the mean's bias: worst "
              f"{result.get('worst_bias_ratio', float('nan')):.2f}x)")
    for failure in failed:
        print(f"  failed: {failure['key'][:12]}: {failure['error']}", file=sys.stderr)
    return 1 if failed else 0


def _scenes(args) -> list | None:
    """``--scenes a,b`` as a list (relative to the working folder); None when not given."""
    return [s.strip() for s in args.scenes.split(",")] if args.scenes is not None else None


def _measured(spec, args):
    """``spec`` with the measurement flags given over its ``[measurement]`` table."""
    given = {name: getattr(args, name) for name in MEASUREMENT_KEYS if getattr(args, name, None) is not None}
    return dataclasses.replace(spec, measurement={**spec.measurement, **given}) if given else spec


def _print_suffice(suffice) -> None:
    from volcaustics.reports.studies.sweep.variants import variant_name

    if suffice is None or not len(suffice):
        return
    print(f"settings that suffice (error within {suffice['factor'].iloc[0]:g}x the best; caustic: debiased "
          f"relative MSE, intersection: the intersection term's own relative MSE):")
    for _, row in suffice.iterrows():
        print(f"  {row['scene']:<12} {variant_name(row):<9} {row['parameter']:<12} "
              f"{row['criterion'].split('_')[0]:<12} {row['suffices']:g} (of {row['largest']:g}): "
              f"{100 * row['error']:.2f}% vs best {100 * row['best']:.2f}%, frame {row['frame_time_s']:.3f} s, "
              f"{row['map_reads_per_frame'] / 1e6:.2f} M map reads")


def _print_crossing(crossing) -> None:
    if crossing is None or not len(crossing):
        return
    print("single-scattering model: the optical depth where its own error overtakes the approximation's "
          "(model_crossing.csv, figures/model_vs_optical_depth):")
    for _, r in crossing.iterrows():
        at = r["overtakes_at_optical_depth"]
        where = f"at {at:.3g}" if at == at and at is not None else "not within"
        print(f"  {r['scene']:<12} {r['component']:<9} {where} (optical depths {r['depth_min']:.3g} to "
              f"{r['depth_max']:.3g})")


def _print_variants(best) -> None:
    from volcaustics.reports.studies.sweep.variants import variant_name

    if best is None or not len(best):
        return
    print("variants: per scene the paper's method and the smallest intersection term (both parts) at no more map "
          "reads per segment (variants_best.csv):")
    for _, r in best.iterrows():
        print(f"  {r['scene']:<12} {r['role']:<6} {variant_name(r)} "
              f"layers {r['layers']} peak_samples {r['peak_samples']} iterations {r['iterations']}: "
              f"{r['map_reads_per_segment']:.1f} reads/segment, frame {r['frame_time_s']:.2f} s, intersection "
              f"{100 * r['share_intersection']:+.1f}% ± {100 * r['share_intersection_se']:.1f}, relMSE part "
              f"{100 * r['intersection_relmse_part']:.2f}% (×{r['share_ratio']:.2f} and ×{r['relmse_ratio']:.2f} of "
              f"the paper's), step 2 wrong surface {r['step2_wrong_surface']:.1f}%, missed {r['step2_missed']:.1f}%")
