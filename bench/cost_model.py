"""Fit the cost model (``approx.cost_model``) to measured pass times and check it on
configurations and scenes left out of the fit.

    .venv/bin/python bench/cost_model.py [--rounds N] [--size PX] [--write] [--json FILE]
        [--points FILE [--measure NAME,...]]
    .venv/bin/python bench/cost_model.py --media [--rounds N] [--size PX] [--write]

Every built-in renders the FIT configurations (changes from the quick preset, one axis
at a time: photon_res, splat_radius, layers, steps, iterations, the searches, the splat
modes, emission, fog_steps, the image size, and ``--preset best``); per configuration
one frame with records gives the counts (``approx.cost.frame_cost``: fragments per pass,
photons, segments, map reads, splats), then ``--rounds`` rounds render every
configuration of the scene once each without records (alternating, so the machine's
drift spreads over all of them) and the median of each pass time is kept. A
non-negative least-squares fit per pass (``scipy.optimize.nnls``) gives the weights;
R² per pass and for the frame, and the frame's prediction error, are printed for the
fit, for the HELD_OUT configurations on the built-ins and for every configuration on
the held-out scenes (``scenes/heldout``). ``--write`` stores the weights with their
provenance as ``approx/cost_weights/<GL kind>.json`` and, anchored in the paper's GPU
pass shares (Table 1: at the paper's configuration trace ≈ 70% and splatting ≈ 23% of a
frame), ``approx/cost_weights/paper_gpu.json`` (``--no-anchor``: the fitted set alone, e.g.
a GPU's beside the shipped anchor).

``--media`` prices a heterogeneous medium's work (``approx.cost``'s medium reads: its
volumes' texels, the march's and delta tracking's samples of ρ, the volumes' reads) on top
of the shipped weight set of this machine's kind: the MEDIA_FIT configurations on
fogbank and smoke (scenes/media) are measured, and per pass the medium reads' weight (and
the ``volumes`` pass's call, a beam fragment's beside its march) is fitted by non-negative
least squares, relative to each frame's time, to what the shipped weights leave
unexplained (a homogeneous frame has no medium reads, so the built-ins'
points could not constrain these weights). Checked on the held-out ``layered_fog``, every
configuration; ``--write`` stores the set with the new weights and the paper anchor again
(whose homogeneous counts, and so its scale, are unchanged).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import platform
import statistics
import sys

from volcaustics.approx.params import BEAMS

FIT = {
    "quick": {}, "res128": {"photon_res": 128}, "res384": {"photon_res": 384},
    "radius0.01": {"splat_radius": 0.01}, "radius0.04": {"splat_radius": 0.04},
    "layers1": {"layers": 1}, "layers2": {"layers": 2}, "layers8": {"layers": 8},
    "steps2": {"steps": 2}, "steps6": {"steps": 6}, "iterations8": {"iterations": 8},
    "dda": {"search": "dda"}, "hiz": {"search": "hiz"}, "secant": {"search": "secant"},
    "adaptive": {"splat": "adaptive"}, "density": {"splat": "density", "splat_neighbours": 8},
    "emission": {"emission": "adaptive"}, "fog24": {"fog_steps": 24}, "size128": {"width": 128, "height": 128},
    "best": {"splat": "density", "splat_neighbours": 8, "fresnel": "stochastic", "steps": 6, "layers": 2,
             "photon_res": 352},
    "beams": {"splat": "beams"}, "beams_radius0.01": {"splat": "beams", "splat_radius": 0.01},
    "beams_steps2": {"splat": "beams", "steps": 2}, "beams_res128": {"splat": "beams", "photon_res": 128},
    "beams_differential": {"splat": "beams", "beam_width": "differential", "splat_radius": 0.01,
                           "splat_footprints": 1.0},
    "beams_differential_fp4": {"splat": "beams", "beam_width": "differential", "photon_res": 128},
    # the beams preset near the photon_res its cost match picks (50-80 a side), and its parts
    "beams_preset": {**BEAMS, "photon_res": 64}, "beams_preset_res96": {**BEAMS, "photon_res": 96},
    "beams_balanced": {**BEAMS, "beam_width": "balanced", "photon_res": 64},
    "beams_splits": {"splat": "beams", "fresnel": "stratified", "fresnel_splits": 2, "split_every": 2,
                     "photon_res": 128},
}
HELD_OUT = {  # never in the fit: several axes at once
    "best300": {"splat": "density", "splat_neighbours": 8, "fresnel": "stochastic", "steps": 6, "layers": 2,
                "photon_res": 300},
    "mixed": {"photon_res": 320, "splat_radius": 0.03, "layers": 3, "steps": 5},
    "density16": {"splat": "density", "splat_neighbours": 16, "splat_radius": 0.03, "photon_res": 200},
    "adaptive3": {"splat": "adaptive", "steps": 3, "photon_res": 200, "search": "dda"},
    "size192": {"width": 192, "height": 192, "photon_res": 300, "layers": 2},
    "beams_mixed": {"splat": "beams", "fresnel": "stochastic", "steps": 6, "layers": 2, "photon_res": 200,
                    "splat_radius": 0.015},
    "beams_differential_mixed": {"splat": "beams", "beam_width": "differential", "fresnel": "stochastic",
                                 "steps": 4, "layers": 2, "photon_res": 150, "splat_radius": 0.01,
                                 "splat_footprints": 2.0},
    "beams_preset_mixed": {**BEAMS, "photon_res": 80, "layers": 3, "steps": 6},
    "beams_balanced_mixed": {**BEAMS, "beam_width": "balanced", "photon_res": 48, "layers": 1},
}
# heterogeneous media (--media): what scales the medium's reads, points and beams
MEDIA_FIT = {
    "quick": {}, "march4": {"march_steps": 4}, "march64": {"march_steps": 64},
    "volumes32": {"camera_volume_res": 32, "camera_volume_slices": 16, "light_volume_res": 32,
                  "light_volume_slices": 16},
    "volumes256": {"camera_volume_res": 256, "camera_volume_slices": 128, "light_volume_res": 256,
                   "light_volume_slices": 128},
    "fog24": {"fog_steps": 24}, "res384": {"photon_res": 384}, "steps6": {"steps": 6},
    "beams_preset": {**BEAMS, "photon_res": 64}, "beams_march4": {**BEAMS, "photon_res": 64, "march_steps": 4},
    "beams_march64": {**BEAMS, "photon_res": 64, "march_steps": 64}, "beams": {"splat": "beams"},
}
MEDIA_SCENES, MEDIA_HELD_OUT = ("fogbank", "smoke"), ("layered_fog",)
PAPER_SHARES = {"trace": 0.70, "splatting": 0.23}  # the paper's Table 1, at its configuration
# the weight files go to the checkout's package folder (an editable install's link tree is not it)
OUT_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "approx", "cost_weights")
SPLATTING = ("splat", "density")


def measure(scene_arg: str, configs: dict, rounds: int, size: int) -> list:
    """Per configuration of one scene: its counts and the median time of every pass."""
    from volcaustics.approx import Renderer
    from volcaustics.approx.cost import TIMED_PASSES, frame_cost
    from volcaustics.approx.params import QUICK
    from volcaustics.scenes import resolve_scene

    scene = resolve_scene(scene_arg)
    renderer = Renderer(scene)
    try:
        params, costs = {}, {}
        for name, changes in configs.items():
            p = dataclasses.replace(QUICK, **{"width": size, "height": size, **changes}).resolved(scene)
            frame = renderer.render(scene, p, keep_records=True)  # the counts; compiles its programs
            params[name], costs[name] = p, frame_cost(frame.records, p, frame.work)
        times = {name: [] for name in configs}
        for _ in range(rounds):
            for name in configs:
                times[name].append(renderer.render(scene, params[name], keep_records=False).timings)
    finally:
        renderer.release()
    rows = []
    for name in configs:
        med = {k: statistics.median(t.get(k, 0.0) for t in times[name])
               for k in {k for t in times[name] for k in t} if not k.startswith("trace_step")}
        passes = {k: med.get(k, 0.0) for k in TIMED_PASSES}
        passes["other"] = max(med["frame_wall"] - sum(passes.values()), 0.0)
        rows.append({"scene": scene_arg, "config": name, "params": params[name], "cost": costs[name],
                     "passes": passes, "frame": med["frame_wall"]})
    return rows


def read_points(path: str, size: int) -> list:
    """The points a ``--json`` run wrote, with their parameters rebuilt from FIT and HELD_OUT."""
    from volcaustics.approx.params import QUICK
    from volcaustics.scenes import resolve_scene

    with open(path, encoding="utf-8") as fh:
        points = json.load(fh)
    configs, scenes = {**FIT, **HELD_OUT}, {}
    for r in points:
        scene = scenes.setdefault(r["scene"], resolve_scene(r["scene"]))
        r["params"] = dataclasses.replace(QUICK, **{"width": size, "height": size, **configs[r["config"]]}).resolved(
            scene)
    return points


def fit(rows: list) -> dict:
    """pass → feature → weight (non-negative least squares per pass) and the fit's R²."""
    import numpy as np
    from scipy.optimize import nnls

    from volcaustics.approx.cost_model import MODEL_PASSES, features

    weights, r2 = {}, {}
    for name in MODEL_PASSES:
        xs = [features(r["cost"], r["params"])[name] for r in rows]
        names = list(xs[0])
        a = np.array([[x[f] for f in names] for x in xs], float)
        y = np.array([r["passes"][name] for r in rows], float)
        scale = np.maximum(a.max(axis=0), 1e-30)  # columns of counts in the millions beside calls of 1
        w, _ = nnls(a / scale, y)
        w = w / scale
        weights[name] = {f: float(v) for f, v in zip(names, w) if v > 0}
        total = float(((y - y.mean()) ** 2).sum())
        r2[name] = 1.0 - float(((a @ w - y) ** 2).sum()) / total if total > 0 else 1.0
    return {"weights": weights, "r2": r2}


def fit_media(rows: list, ws) -> dict:
    """pass → feature → weight: ``ws``'s weights with, per pass, the medium reads' weight (the
    ``volumes`` pass: its call's too; the splat pass: a beam fragment's beside its march)
    fitted by non-negative least squares, relative to each frame's time, to what ``ws``
    leaves unexplained in ``rows`` (heterogeneous frames); and the R² of that fit per pass
    (of the relative residuals)."""
    import numpy as np
    from scipy.optimize import nnls

    from volcaustics.approx.cost_model import MODEL_PASSES, features

    weights, r2 = {name: dict(w) for name, w in ws.weights.items()}, {}
    for name in MODEL_PASSES:
        xs = [features(r["cost"], r["params"])[name] for r in rows]
        names = [f for f in ("calls", "medium_reads", "medium_fragments") if f in xs[0]
                 and (f != "calls" or name == "volumes")]
        if "medium_reads" not in names:
            continue
        # relative to each frame's time: the 25-s frames of default beams must not outweigh the presets'
        frame = np.array([r["frame"] for r in rows], float)[:, None]
        a = np.array([[x[f] for f in names] for x in xs], float) / frame
        y = np.array([r["passes"][name] - ws.predict(r["cost"], r["params"])[name] for r in rows], float) / frame[:, 0]
        scale = np.maximum(a.max(axis=0), 1e-30)
        w, _ = nnls(a / scale, y)
        w = w / scale
        weights[name] = {**weights.get(name, {}), **{f: float(v) for f, v in zip(names, w) if v > 0}}
        total = float(((y - y.mean()) ** 2).sum())
        r2[name] = 1.0 - float(((a @ w - y) ** 2).sum()) / total if total > 0 else 1.0
    return {"weights": weights, "r2": r2}


def media(args, argv) -> int:
    """--media: the shipped set of this machine's kind extended with a heterogeneous medium's weights."""
    from volcaustics.approx.context import shared_context
    from volcaustics.approx.cost_model import weight_sets
    from volcaustics.scenes.catalogue import heldout_path

    renderer_name = shared_context().info["GL_RENDERER"]
    kind = "llvmpipe" if "llvmpipe" in renderer_name.lower() else "gpu_" + "".join(
        c if c.isalnum() else "_" for c in renderer_name.lower()).strip("_")[:40]
    ws = weight_sets()[kind]
    rows, held = [], []
    for name in MEDIA_SCENES + MEDIA_HELD_OUT:
        measured = measure(name if name in MEDIA_SCENES else heldout_path(name), MEDIA_FIT, args.rounds, args.size)
        (held if name in MEDIA_HELD_OUT else rows).extend(measured)
        print(f"{name}: {len(measured)} configurations", flush=True)
    before = {"fit": summary("before, fit scenes", errors(rows, ws)), "held_out": summary("before, held out",
                                                                                          errors(held, ws))}
    fitted = fit_media(rows, ws)
    extended = dataclasses.replace(ws, weights=fitted["weights"])
    print("R² of the medium reads' fit per pass: " + ", ".join(f"{k} {v:.3f}" for k, v in fitted["r2"].items()))
    report = {"fit": summary("fit (fogbank, smoke x MEDIA_FIT)", errors(rows, extended)),
              "held_out": summary("held-out layered_fog, every configuration", errors(held, extended))}
    print("\n| scene | config | measured ms | predicted before ms | predicted ms | error |\n"
          "|---|---|---:|---:|---:|---:|")
    for (r, pred, e), (_, old, _) in zip(errors(rows + held, extended), errors(rows + held, ws)):
        print(f"| {os.path.basename(r['scene']).removesuffix('.toml')} | {r['config']} | {1000 * r['frame']:.0f} | "
              f"{1000 * old:.0f} | {1000 * pred:.0f} | {100 * e:+.1f}% |")
    provenance = {**ws.provenance, "media_fit": {
        "scenes": list(MEDIA_SCENES), "configs": MEDIA_FIT, "held_out_scenes": list(MEDIA_HELD_OUT),
        "size": args.size, "rounds": args.rounds, "r2": fitted["r2"], "before": before, **report,
        "date": datetime.date.today().isoformat(), "gl_renderer": renderer_name,
        "command": "bench/cost_model.py " + " ".join(argv if argv is not None else sys.argv[1:])}}
    if args.write:
        write_sets([dataclasses.replace(extended, provenance=provenance), *([paper_anchor(extended, "two_spheres")]
                                                                            if args.anchor else [])])
    return 0


def write_sets(sets: list) -> None:
    """Store each weight set as approx/cost_weights/<name>.json (a temporary file, then renamed)."""
    for s in sets:
        path = os.path.join(OUT_DIR, f"{s.name}.json")
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(s.to_dict(), fh, indent=1, sort_keys=True)
        os.replace(tmp, path)
        print(f"wrote {path}")


def errors(rows: list, ws) -> list:
    """Per row: measured frame, predicted frame, relative error."""
    return [(r, ws.frame(r["cost"], r["params"]), ws.frame(r["cost"], r["params"]) / r["frame"] - 1.0)
            for r in rows]


def summary(label: str, errs: list) -> dict:
    rel = [abs(e) for _, _, e in errs]
    out = {"points": len(rel), "median_abs_error": statistics.median(rel), "max_abs_error": max(rel)}
    print(f"{label}: {len(rel)} points, frame time error median {100 * out['median_abs_error']:.1f}%, "
          f"max {100 * out['max_abs_error']:.1f}%")
    return out


def paper_anchor(ws, scene_arg: str):
    """A weight set with ``ws``'s per-pass weights rescaled so that at the paper's
    configuration on ``scene_arg`` trace is 70% and splatting 23% of the frame, the rest
    7%, in units of that frame (the paper's Table 1 gives shares, not counts)."""
    from volcaustics.approx import Renderer
    from volcaustics.approx.cost import frame_cost
    from volcaustics.approx.cost_model import WeightSet
    from volcaustics.approx.params import PAPER
    from volcaustics.scenes import resolve_scene

    scene = resolve_scene(scene_arg)
    renderer = Renderer(scene)
    try:
        p = PAPER.resolved(scene)
        frame = renderer.render(scene, p, keep_records=True)
        cost = frame_cost(frame.records, p, frame.work)
    finally:
        renderer.release()
    t = ws.predict(cost, p)
    group = {name: "trace" if name == "trace" else "splatting" if name in SPLATTING else "rest"
             for name in ws.weights}
    shares = {**PAPER_SHARES, "rest": 1.0 - sum(PAPER_SHARES.values())}
    spent = {g: sum(t[n] for n in t if group.get(n) == g) for g in shares}
    scale = {g: shares[g] / spent[g] for g in shares}
    weights = {n: {f: w * scale[group[n]] for f, w in fw.items()} for n, fw in ws.weights.items()}
    return WeightSet(name="paper_gpu", unit="the paper configuration's frame", weights=weights, provenance={
        "anchor": "Wang, Wang & Chen, Table 1: at the paper's configuration (800x800, photon_res 1500, 4 layers, "
                  "4 steps) intersection estimation ~70% and splatting ~23% of a frame on their GPU",
        "from": ws.name, "splat_modes": list(ws.splat_modes), "scene": scene_arg, "paper_counts": cost,
        "method": "the fitted set's per-pass weights scaled per group (trace; splat and density; the rest) to "
                  "those shares at that frame, which is 1 unit", "date": datetime.date.today().isoformat()})


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="timed frames per configuration (median)")
    parser.add_argument("--size", type=int, default=256, help="image size (px, square)")
    parser.add_argument("--scenes", help="fit scenes (default: every built-in)")
    parser.add_argument("--write", action="store_true", help="store the weight sets in approx/cost_weights/")
    parser.add_argument("--json", help="write every measured point to this file")
    parser.add_argument("--points", help="fit the points a --json run wrote instead of measuring (same --size)")
    parser.add_argument("--measure", help="with --points: measure these configurations (names, comma-separated) "
                        "anew on every scene and take the others from the file")
    parser.add_argument("--anchor", action=argparse.BooleanOptionalAction, default=True,
                        help="with --write, also write paper_gpu.json anchored in this fit (default: yes)")
    parser.add_argument("--media", action="store_true",
                        help="extend this machine's shipped weight set with a heterogeneous medium's weights")
    args = parser.parse_args(argv)
    if args.media:
        return media(args, argv)

    from volcaustics.approx.context import shared_context
    from volcaustics.approx.cost_model import WeightSet, config_splat_modes
    from volcaustics.scenes.catalogue import BUILTIN_NAMES, HELDOUT_NAMES, heldout_path

    fit_scenes = args.scenes.split(",") if args.scenes else list(BUILTIN_NAMES)
    configs = {**FIT, **HELD_OUT}
    anew = args.measure.split(",") if args.measure else []
    unknown = [name for name in anew if name not in configs]
    if unknown or (anew and not args.points):
        parser.error(f"--measure: {', '.join(unknown) or 'needs --points'} "
                     f"(configurations: {', '.join(configs)})")
    points = [r for r in read_points(args.points, args.size) if r["config"] not in anew] if args.points else None

    def scene_points(scene_arg: str) -> list:
        """The scene's points: measured, or from --points with the --measure ones measured anew."""
        if points is None:
            return measure(scene_arg, configs, args.rounds, args.size)
        stored = [r for r in points if os.path.basename(r["scene"]) == os.path.basename(scene_arg)]
        return stored + (measure(scene_arg, {n: configs[n] for n in anew}, args.rounds, args.size) if anew else [])

    rows, held, held_scenes = [], [], []
    for scene in fit_scenes:
        measured = scene_points(scene)
        rows += [r for r in measured if r["config"] in FIT]
        held += [r for r in measured if r["config"] in HELD_OUT]
        print(f"{scene}: {len(measured)} configurations", flush=True)
    for name in HELDOUT_NAMES:
        if name in MEDIA_HELD_OUT:  # a density grid: its reads are --media's weights, not this fit's
            continue
        held_scenes += scene_points(heldout_path(name))
        print(f"{name} (held out): measured", flush=True)
    fitted = fit(rows)
    renderer_name = shared_context().info["GL_RENDERER"]
    kind = "llvmpipe" if "llvmpipe" in renderer_name.lower() else "gpu_" + "".join(
        c if c.isalnum() else "_" for c in renderer_name.lower()).strip("_")[:40]
    ws = WeightSet(name=kind, unit="s", weights=fitted["weights"])
    print("R² per pass: " + ", ".join(f"{k} {v:.3f}" for k, v in fitted["r2"].items()))
    report = {"fit": summary("fit (built-ins x FIT)", errors(rows, ws)),
              "held_out_configs": summary("held-out configurations on the built-ins", errors(held, ws)),
              "held_out_scenes": summary("held-out scenes, every configuration", errors(held_scenes, ws))}
    print("\n| scene | config | measured ms | predicted ms | error |\n|---|---|---:|---:|---:|")
    for r, pred, e in errors(held + held_scenes, ws):
        print(f"| {os.path.basename(r['scene']).removesuffix('.toml')} | {r['config']} | {1000 * r['frame']:.0f} | "
              f"{1000 * pred:.0f} | {100 * e:+.1f}% |")
    # what the fit saw: the configurations its rows have (a points file from before a
    # configuration was added lacks it, and the set must not price what it never measured)
    fitted_configs = {name: FIT[name] for name in FIT if any(r["config"] == name for r in rows)}
    provenance = {"gl_renderer": renderer_name,
                  "splat_modes": list(config_splat_modes(fitted_configs)),
                  "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
                  f"{platform.system()} {platform.release()}", "date": datetime.date.today().isoformat(),
                  "fit": {"scenes": fit_scenes, "configs": fitted_configs, "size": args.size, "rounds": args.rounds,
                          "r2": fitted["r2"], **report["fit"]},
                  "held_out": {"configs": HELD_OUT, "scenes": list(HELDOUT_NAMES),
                               "configs_on_builtins": report["held_out_configs"],
                               "scenes_every_config": report["held_out_scenes"]},
                  "command": "bench/cost_model.py " + " ".join(argv if argv is not None else sys.argv[1:])}
    ws = dataclasses.replace(ws, provenance=provenance)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([{"scene": r["scene"], "config": r["config"], "cost": r["cost"], "passes": r["passes"],
                        "frame": r["frame"]} for r in rows + held + held_scenes], fh)
    if args.write:
        write_sets([ws, paper_anchor(ws, "two_spheres")] if args.anchor else [ws])
    return 0


if __name__ == "__main__":
    sys.exit(main())
