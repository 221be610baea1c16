"""One frame's error against the mean's bias, per built-in and configuration, at the
report's settings (quick preset, 6 seeds, the report's reference; the gate's scope: no
decomposition).

    .venv/bin/python bench/one_frame.py [SCENE ...] [--configs paper,sobol,oidn,sobol+oidn,best] [--json FILE]

Configurations: ``paper`` (the quick preset), ``random`` / ``sobol`` (``emission_jitter``),
``oidn`` (``denoise``), ``sobol+oidn`` and ``best`` (``--preset best`` at its cost-matched
photon_res; ``best+oidn`` etc. with a configuration's changes), or ``NAME=VALUE/NAME=VALUE``
(any parameters on the quick preset, e.g. ``splat=density/splat_neighbours=4``). Per point:
the predicted cost (the largest ratio over the cost model's weight sets) and measured frame
time (alternating frames, ``reports.measuring.cost_match.measured_time_ratio``) against the
paper's, one frame's caustic relMSE less the reference's floor ± SE (``metrics.frame``),
the seeds' mean's debiased relMSE ± SE, their ratios to the paper's, HDR-FLIP per frame,
and the denoiser's seconds and pixels beside the frame's. Runs the
code of the checkout it is started from.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

CONFIGS = {"paper": {}, "random": {"emission_jitter": "random"}, "sobol": {"emission_jitter": "sobol"},
           "oidn": {"denoise": "oidn"}, "sobol+oidn": {"emission_jitter": "sobol", "denoise": "oidn"}}


def config_params(name: str, scene: str):
    from volcaustics.approx.params import PRESETS, QUICK
    from volcaustics.reports.measuring.cost_match import with_auto_values

    if name == "best" or name.startswith("best+"):
        best = with_auto_values(scene, PRESETS["best"], "best", given=False)
        return dataclasses.replace(best, **CONFIGS[name.split("+", 1)[1]]) if "+" in name else best
    if "=" in name:  # NAME=VALUE/NAME=VALUE…: any parameters on the quick preset
        from volcaustics.approx.params import param

        pairs = dict(item.split("=", 1) for item in name.split("/"))
        return dataclasses.replace(QUICK, **{k: param(k).parse(v) for k, v in pairs.items()})
    if name not in CONFIGS:
        raise SystemExit(f"--configs: unknown configuration {name!r} ({', '.join([*CONFIGS, 'best'])})")
    return dataclasses.replace(QUICK, **CONFIGS[name])


def main(argv=None) -> int:
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.experiment.pipeline import run_experiment
    from volcaustics.experiment.sizing import REPORT_REFERENCE, sized
    from volcaustics.reference.render import render_reference
    from volcaustics.reports.measuring.cost_match import measured_time_ratio
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.catalogue import BUILTIN_NAMES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=list(BUILTIN_NAMES))
    parser.add_argument("--configs", default="paper,sobol,oidn,sobol+oidn,best")
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--json", help="append one JSON object per point to this file")
    args = parser.parse_args(argv)
    print("| scene | config | photon_res | predicted cost ratio | measured time ratio | one frame relMSE | × paper | "
          "debiased relMSE | × paper | HDR-FLIP | denoise s/frame |\n|---|---|---|---|---|---|---|---|---|---|---|",
          flush=True)
    for name in args.scenes:
        scene = resolve_scene(name)
        paper = None
        for config in args.configs.split(","):
            p = config_params(config, name)
            reference = render_reference(scene, sized(REPORT_REFERENCE, scene, p), progress=False)
            t0 = time.perf_counter()
            s = run_experiment(scene, p, seeds=args.seeds, reference=reference,
                               measurement=MeasurementSettings(scope="gate")).summary
            c = s["images"]["caustic"]
            point = {"scene": name, "config": config, "seconds": time.perf_counter() - t0, "cost": s["cost"],
                     "predicted": s["predicted_frame"], "photon_res": p.photon_res,
                     "time": measured_time_ratio(name, p, config_params("paper", name))["ratio"],
                     "frame": c["frame_relative_mse"], "mean": c["relative_mse"], "flip": c["hdr_flip"]["value"],
                     "denoise_s": s["approx_timings_s"].get("denoise")}
            paper = paper or point
            one, mean = point["frame"], point["mean"]
            predicted = max(v / paper["predicted"][k] for k, v in point["predicted"].items())
            print(f"| {name} | {config} | {p.photon_res} | {predicted:.3f} | {point['time']:.2f} | "
                  f"{100 * one['debiased']:.2f}% ± {100 * (one['standard_error'] or 0):.2f} | "
                  f"{one['debiased'] / paper['frame']['debiased']:.2f} | "
                  f"{100 * mean['debiased']:.2f}% ± {100 * (mean['standard_error'] or 0):.2f} | "
                  f"{max(mean['debiased'], 0) / paper['mean']['debiased']:.2f} | {point['flip']:.3f} | "
                  f"{point['denoise_s'] or 0:.2f} |", flush=True)
            if args.json:
                with open(args.json, "a") as fh:
                    fh.write(json.dumps(point) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
