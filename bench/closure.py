"""Does the decomposition close? Every term and the residual's z-values per built-in and
configuration, at the report's settings (quick preset, the budgets' 6 seeds, the
report's reference, 16 sub-photons).

    .venv/bin/python bench/closure.py [SCENE ...] [--configs paper,adaptive,best] [--json FILE]
    .venv/bin/python bench/closure.py --table AFTER.jsonl [BEFORE.jsonl]

SCENE: a built-in name or a scene file (``scenes/heldout/knot.toml``). Configurations:
``paper`` (the quick preset: the paper's method at the harness's size, fixed splats),
``adaptive`` (the same with adaptive splats and ``emission = adaptive``) and ``best``
(``--preset best``: density splats, photon_res matched to the paper's frame cost as the
commands match it). The goal: the residual's debiased relMSE
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
    from volcaustics.approx.params import PRESETS, QUICK
    from volcaustics.reports.measuring.cost_match import with_auto_values

    if name == "paper":
        return QUICK
    if name == "adaptive":
        return dataclasses.replace(QUICK, splat="adaptive", emission="adaptive")
    if name == "best":
        return with_auto_values(scene, PRESETS["best"], "best", given=False)
    raise SystemExit(f"--configs: unknown configuration {name!r} (paper, adaptive, best)")


def main(argv=None) -> int:
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.experiment.pipeline import run_experiment
    from volcaustics.experiment.sizing import REPORT_REFERENCE, sized
    from volcaustics.reference.render import render_reference
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.catalogue import BUILTIN_NAMES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=list(BUILTIN_NAMES))
    parser.add_argument("--configs", default="paper,adaptive,best")
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--json", help="append one JSON object per point to this file")
    parser.add_argument("--table", nargs="+", metavar="FILE",
                        help="print the points of --json files as markdown tables (a second FILE: before → after)")
    args = parser.parse_args(argv)
    if args.table:
        return print_tables(*args.table)
    for name in args.scenes:
        scene = resolve_scene(name)
        for config in args.configs.split(","):
            p = config_params(config, name)
            reference = render_reference(scene, sized(REPORT_REFERENCE, scene, p), progress=False)
            t0 = time.perf_counter()
            d = run_experiment(scene, p, seeds=args.seeds, reference=reference, progress=False,
                               measurement=MeasurementSettings(scope="decomposition")).summary["decomposition"]
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


def print_tables(after: str, before: str | None = None) -> int:
    """Markdown: per point every term's energy share and debiased relMSE part (± SE, % and
    % points), then the residual's z-values (``before`` → after when given)."""
    def load(path):
        with open(path) as fh:
            return {(p["scene"], p["config"]): p for p in map(json.loads, fh)}

    now, then = load(after), load(before) if before else {}
    for (scene, config), point in now.items():
        rows = [r for r in point["rows"] if "energy_share" in r]
        print(f"\n**{scene}, {config}**\n\n| term | energy share % | relMSE part, debiased (pts) |\n|---|---|---|")
        for r in rows:
            print(f"| {r['term']} | {100 * r['energy_share']:+.2f} ± {100 * r['energy_share_se']:.2f} | "
                  f"{100 * r['relmse_part_debiased']:+.3f} ± {100 * r['relmse_part_se']:.3f} |")
        res, old = point["residual"], then.get((scene, config), {}).get("residual")
        was = (f"{old['energy_z']:+.1f} / {100 * old['debiased_relmse']:+.3f}% (z {old['relmse_z']:+.1f}) → "
               if old else "")
        print(f"\nresidual energy z / relMSE: {was}{res['energy_z']:+.1f} / {100 * res['debiased_relmse']:+.3f}% "
              f"(z {res['relmse_z']:+.1f})")
    print("\n| scene | config | residual relMSE part (pts) | energy z | relMSE z | largest term energy SE % |"
          "\n|---|---|---|---|---|---|")
    for (scene, config), point in now.items():
        rows = {r["term"]: r for r in point["rows"] if "energy_share" in r}
        res, old = point["residual"], then.get((scene, config), {}).get("residual")
        was = {key: f"{old[key]:+.1f} → " if old else "" for key in ("energy_z", "relmse_z")}
        part = rows["residual"]["relmse_part_debiased"]
        print(f"| {scene} | {config} | {100 * part:+.3f} | {was['energy_z']}{res['energy_z']:+.1f} | "
              f"{was['relmse_z']}{res['relmse_z']:+.1f} | "
              f"{100 * max(r['energy_share_se'] for t, r in rows.items() if t != 'total'):.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
