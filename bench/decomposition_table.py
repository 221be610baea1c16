"""The closing-note tables of the metrics issue: for every scene, the caustic error
decomposed, and the step-2 hit classes for both layer strategies.

    .venv/bin/python bench/decomposition_table.py [SCENE ...] [--seeds 2] [--out DIR]

Quick preset (256², photon_res 256, light_res 256), the report's reference (cached
by ``make report``; else rendered first). Prints two Markdown tables; with ``--out``
also writes every experiment's outputs under DIR/SCENE-STRATEGY/.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys


def main(argv=None) -> int:
    from volcaustics.approx.params import QUICK
    from volcaustics.experiment.pipeline import run_experiment
    from volcaustics.metrics.decomposition import TERMS
    from volcaustics.metrics.intersection import CLASS_NAMES
    from volcaustics.reports.presenting.exports.measure_files import write_experiment
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.catalogue import BUILTIN_NAMES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=list(BUILTIN_NAMES))
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--out", help="also write each experiment's outputs here")
    args = parser.parse_args(argv)
    OTHER = [c for c in CLASS_NAMES.values() if c != "self_rehit"]
    terms = (*TERMS, "total", "noise")
    decomposition, classes = [], []
    for name in args.scenes:
        scene = resolve_scene(name)
        for strategy in ("threshold", "peel"):
            params = dataclasses.replace(QUICK, layer_strategy=strategy)
            result = run_experiment(scene, params, seeds=args.seeds)
            if args.out:
                write_experiment(result, f"{args.out}/{name}-{strategy}")
            s = result.summary
            rows = {r["term"]: r for r in s["decomposition"]["rows"]}
            res = s["decomposition"]["residual"]
            relmse = s["images"]["caustic"]["relative_mse"]
            if strategy == "threshold":
                decomposition.append(
                    f"| {name} | " + " | ".join(f"{100 * rows[t]['energy_share']:+.1f} ± "
                                                f"{100 * rows[t]['energy_share_se']:.1f}" for t in terms[:6])
                    + f" | {100 * rows['noise']['energy_sigma']:.1f}"
                    + f" | {res['energy_z']:+.1f} / {res['relmse_z']:+.1f} | {100 * relmse['debiased']:.1f} | "
                    + " | ".join(f"{100 * rows[t]['relmse_part']:+.2f}" for t in terms[:5]) + " |")
            step2 = [r for r in result.segments if r["grouping"] == "step" and r["step"] == 2][0]
            n = step2["segments"]
            classes.append(f"| {name} | {strategy} | {n:,} | "
                           + " | ".join(f"{100 * (step2[f'count_{c}'] + step2[f'count_beyond_self_rehit_{c}']) / n:.1f}"
                                        for c in OTHER)
                           + f" | {100 * step2['share_self_rehit']:.1f} | {1000 * step2['abs_dt_median']:.2f} | "
                           f"{1000 * step2['abs_dt_p90']:.2f} |")
            print(f"done {name} {strategy} ({s['experiment_seconds']['total']:.1f} s)", file=sys.stderr, flush=True)
    print("Caustic energy shares ± SE (% of the reference's energy; total = 1 − energy ratio; noise = 1σ), the "
          "residual's z (energy / relMSE), debiased relMSE (%), and the parts of the relMSE (%), threshold layers:\n")
    print("| scene | " + " | ".join(terms) + " | residual z | relMSE | " + " | ".join(f"{t} part" for t in terms[:5])
          + " |")
    print("|" + "---|" * (len(terms) + 8))
    print("\n".join(decomposition))
    print("\nStep-2 segments by class (% of the step's segments; a self re-hit counted by its class beyond the "
          "re-hit surface, and its share given apart), |Δt| of true hits (mm):\n")
    print("| scene | layer_strategy | segments | " + " | ".join(OTHER) + " | of which self re-hits | |Δt| median | "
          "|Δt| p90 |")
    print("|" + "---|" * (len(CLASS_NAMES) + 5))
    print("\n".join(classes))
    return 0


if __name__ == "__main__":
    sys.exit(main())
