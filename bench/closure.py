"""Does the decomposition close? Every term and the residual's z-values per built-in and
configuration, at the report's settings (quick preset, the budgets' 6 seeds, the
report's reference, 16 sub-photons).

    .venv/bin/python bench/closure.py [SCENE ...] [--configs paper,adaptive,adopted] [--json FILE]

Configurations: ``paper`` (the quick preset: the paper's method at the harness's size),
``adaptive`` (the same with ``emission = adaptive``) and ``adopted`` (the best search's
configuration, ``reports.sweep.adopted``). The goal (issue 37): the residual's debiased relMSE
part ≤ 0.2 points and |z| ≤ 3 for its energy and relMSE, every term to ±1% of the
reference's energy. Prints one block per point and, with ``--json``, appends one JSON
object per point (the decomposition's rows and residual) to FILE. Runs the code of the
checkout it is started from (a worktree of an older commit gives its "before").
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time


def config_params(name: str, scene: str):
    from volcaustics.approx.params import QUICK
    from volcaustics.reports.sweep.adopted import adopted_params

    if name == "paper":
        return QUICK
    if name == "adaptive":
        return dataclasses.replace(QUICK, emission="adaptive")
    if name == "adopted":
        return adopted_params(QUICK, scene)
    raise SystemExit(f"--configs: unknown configuration {name!r} (paper, adaptive, adopted)")


def main(argv=None) -> int:
    from volcaustics.reference.render import render_reference
    from volcaustics.reports.core.sizing import REPORT_REFERENCE, sized
    from volcaustics.reports.experiment.run import run_experiment
    from volcaustics.scenes import load_builtin
    from volcaustics.scenes.catalogue import BUILTIN_NAMES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=list(BUILTIN_NAMES))
    parser.add_argument("--configs", default="paper,adaptive,adopted")
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--json", help="append one JSON object per point to this file")
    args = parser.parse_args(argv)
    for name in args.scenes:
        scene = load_builtin(name)
        for config in args.configs.split(","):
            p = config_params(config, name)
            reference = render_reference(scene, sized(REPORT_REFERENCE, scene, p), progress=False)
            t0 = time.perf_counter()
            d = run_experiment(scene, p, seeds=args.seeds, reference=reference, progress=False).summary[
                "decomposition"]
            seconds = time.perf_counter() - t0
            res = d["residual"]
            print(f"== {name} {config} ({seconds:.0f} s): residual energy z {res['energy_z']:+.2f}, "
                  f"relMSE {100 * res['debiased_relmse']:+.3f}% z {res['relmse_z']:+.2f}", flush=True)
            for row in d["rows"]:
                if "energy_share" in row:
                    print(f"   {row['term']:13} energy {100 * row['energy_share']:+7.2f} ± "
                          f"{100 * row['energy_share_se']:.2f}%   relMSE part {100 * row['relmse_part_debiased']:+7.3f}"
                          f" ± {100 * row['relmse_part_se']:.3f}")
            if args.json:
                with open(args.json, "a") as fh:
                    fh.write(json.dumps({"scene": name, "config": config, "seconds": seconds, "rows": d["rows"],
                                         "residual": res}) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
