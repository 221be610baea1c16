"""The ``volcaustics`` command line: parses arguments and calls the libraries.

Scene problems (:class:`scenes.SceneError`) print on one or two lines and exit 2,
never a traceback.
"""

from __future__ import annotations

import argparse
import sys

EXIT_USAGE = 2


class UsageError(ValueError):
    """A command-line value that cannot work (an output path, a list of names); the
    message names the option, the value and the fix."""

    def __init__(self, option: str, value, fix: str):
        super().__init__(f"{option} = {value!r}: {fix}")


def _cmd_doctor(args) -> int:
    from volcaustics.reports.core.doctor import format_report, run_doctor

    report = run_doctor()
    print(format_report(report))
    return 0 if report.ok else EXIT_USAGE


def _write_preview(scene, folder: str) -> str:
    import os

    from volcaustics.approx.context import shared_context
    from volcaustics.approx.preview import render_preview
    from volcaustics.scenes.imageio import write_png

    path = os.path.join(folder, f"{scene.name}.png")
    write_png(path, render_preview(shared_context(), scene))
    return path


def _cmd_scenes(args) -> int:
    from volcaustics.scenes import BUILTIN_NAMES, load_builtin, load_scene

    if args.preview is not None:
        _check_output_dir(args.preview, "--preview")
    if args.check:
        scene = load_scene(args.check)
        tris = scene.specular_triangle_count()
        print(f"ok: {args.check}: scene '{scene.name}', {len(scene.specular)} specular object(s) "
              f"({tris:,} triangles), {len(scene.diffuse)} diffuse, scene_hash {scene.scene_hash()[:12]}")
        if args.preview:
            print(f"preview -> {_write_preview(scene, args.preview)}")
        return 0
    print(f"{'name':<12} {'triangles':>10}  description")
    for name in BUILTIN_NAMES:
        scene = load_builtin(name)
        print(f"{name:<12} {scene.specular_triangle_count():>10,}  {scene.description}")
        if args.preview:
            _write_preview(scene, args.preview)
    if args.preview:
        print(f"previews -> {args.preview}/")
    return 0


def _cmd_report(args) -> int:
    from volcaustics.reports.page.collect import run_report
    from volcaustics.reports.gate.run import default_budgets_path, load_budgets
    from volcaustics.reports.page.summary import OUTPUT_FILES

    _check_output_set(args.out, "--out", files=OUTPUT_FILES, folders=("figures",))
    names = _scene_list(args.scenes, "--scenes")
    budgets = load_budgets(args.budgets or default_budgets_path())
    if names is None:
        from volcaustics.scenes import BUILTIN_NAMES

        names = list(BUILTIN_NAMES)
    summary = run_report(args.out, names, overrides=_overrides(args.set), seeds=args.seeds, seed=args.seed,
                         reference_settings=_report_settings(args), budgets=budgets, baseline_dir=args.baseline,
                         sweep_dir=args.sweep, progress=not args.quiet)
    for page in summary["scenes"]:
        c = page["components"]
        failed = [ch["name"] for ch in page["gate"]["checks"] if not ch["passed"]]
        gate = ("FAIL " + ", ".join(failed)) if failed else ("pass" if page["gate"]["checks"] else "not checked")
        print(f"{page['scene']:<12} caustic relMSE {_pct(c['caustic']['relative_mse'].get('debiased'))}, "
              f"energy {_num(c['caustic']['energy_ratio'].get('value'))}; combined relMSE "
              f"{_pct(c['combined']['relative_mse'].get('debiased'))}; gate {gate}")
    gate = summary["gate"]
    print(f"report: {len(summary['scenes'])} scenes, gate {'passed' if gate['passed'] else 'FAILED' if gate['failed'] else 'not checked'} "
          f"({gate['failed']} of {gate['checks']} checks failed), {summary['seconds']['total']:.0f} s -> "
          f"{args.out}/index.html")
    return 0


def _scene_list(text, option: str):
    """A comma-separated list of SCENE arguments; None when not given; an empty list
    or an empty name is an error (not "everything")."""
    if text is None:
        return None
    names = [s.strip() for s in text.split(",")]
    if not names or any(not n for n in names):
        raise UsageError(option, text, "expected comma-separated scene names (built-in names or .toml files)")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise UsageError(option, text, f"{repeated[0]!r} is named twice: name each scene once")
    return names


def _overrides(assignments) -> dict:
    """``--set NAME=VALUE`` (repeatable) as approximation parameters; ``seed`` has its own option."""
    from volcaustics.reports.sweep.run import parse_assignment

    overrides = {}
    for text in assignments or []:
        name, values = parse_assignment(text, "--set")
        if len(values) != 1:
            raise UsageError("--set", text, "one value per parameter")
        if name in overrides:
            raise UsageError("--set", text, f"{name} is set twice: set it once")
        if name == "seed":
            raise UsageError("--set", text, "use --seed (the first of the --seeds seeds)")
        overrides[name] = values[0]
    return overrides


def _approx_params(args):
    import dataclasses

    from volcaustics.approx.params import QUICK, ApproxParams

    base = {"paper": ApproxParams(), "quick": QUICK}[args.preset]
    changes = {name: getattr(args, name) for name in ApproxParams.names()
               if getattr(args, name, None) is not None}
    return dataclasses.replace(base, **changes)


def _pct(x) -> str:
    return "   n/a" if x is None else f"{100 * x:6.2f}%"


def _num(x) -> str:
    return "n/a" if x is None else f"{x:.3f}"


def _cmd_approx(args) -> int:
    from volcaustics.scenes import resolve_scene

    from volcaustics.reports.render.approx import run_approx

    _check_output_file(args.output, "-o", ".exr", (".png", ".json", ".records.npz"))
    if args.records_max < -1:
        raise UsageError("--records-max", args.records_max, "expected 0 (none), -1 (all) or a positive count")
    scene = resolve_scene(args.scene)
    params = _approx_params(args)
    summary = run_approx(scene, params, args.output, records_max=args.records_max)
    t = summary["timings_s"]
    print(f"approx {scene.name}: {t['frame_wall']:.2f} s ({summary['timing_method']}), "
          f"trace {t['trace']:.2f} s, splat {t['splat']:.2f} s -> {summary['outputs']['exr']}")
    return 0


def _cmd_reference(args) -> int:
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes import resolve_scene

    from volcaustics.reports.render.reference import run_reference

    _check_output_file(args.output, "-o", ".exr", (".png", ".json"))
    scene = resolve_scene(args.scene)
    settings = ReferenceSettings(photons=args.photons, spp=args.spp, batches=args.batches,
                                 max_scatter=args.max_scatter, width=args.width, height=args.height, seed=args.seed,
                                 **_budget(args))
    summary = run_reference(scene, settings, args.output, force=args.force)
    source = "cache" if summary["cached"] else f"rendered in {summary['seconds_this_call']:.1f} s"
    floors = ", ".join(f"{k} {100 * v:.3f}%" for k, v in summary["noise_floor"].items() if v is not None)
    print(f"reference {scene.name}: {summary['photons']:,} photons, {summary['batches']} + "
          f"{summary['camera_batches']} batches ({source}, {summary['mitsuba_variant']}; stopped by "
          f"{summary['stopped_by']}); noise floor {floors} -> {summary['outputs']['exr']}")
    return 0


def _check_output_file(path: str, option: str, extension: str, siblings: tuple = ()) -> None:
    """Fail before any work when the output file ``path`` (and the sibling outputs named
    after it, ``siblings``: suffixes replacing ``extension``) cannot be written: an empty
    name, a folder, a name without a stem or with another extension, a parent that cannot
    be (or become) a writable folder."""
    import os

    name = os.path.basename(path or "")
    if not path or path.endswith(("/", os.sep)) or name in (".", ".."):
        raise UsageError(option, path, f"expected a file name ending in {extension}")
    if not name.lower().endswith(extension) or len(name) == len(extension):
        raise UsageError(option, path, f"expected a file name ending in {extension}, e.g. out{extension}"
                                       + (" (the other outputs take its stem)" if siblings else ""))
    stem = path[: -len(extension)]
    _check_no_folder_at([path, *(stem + suffix for suffix in siblings)], option, path)
    _check_output_dir(os.path.dirname(os.path.abspath(path)), option)


def _check_no_folder_at(files, option: str, value) -> None:
    """Fail before any work when a folder is where one of the output ``files`` goes (the
    set's last rename would fail after the work, halfway through the set)."""
    import os

    for path in files:
        if os.path.isdir(path):
            raise UsageError(option, value, f"{path} is a folder where an output file goes: move it or choose "
                                            f"another name")


def _check_output_set(folder: str, option: str, files=(), folders=()) -> None:
    """``folder`` must be (or become) a writable folder holding no folder where one of
    its output ``files`` goes and no file where one of its ``folders`` goes."""
    import os

    _check_output_dir(folder, option)
    _check_no_folder_at([os.path.join(folder, name) for name in files], option, folder)
    for name in folders:
        _check_output_dir(os.path.join(folder, name), option)


def _check_output_dir(path: str, option: str = "-o") -> None:
    """Fail before any work when ``path`` cannot be (or become) a writable folder."""
    import os

    if not path:
        raise UsageError(option, path, "expected an output folder")
    if os.path.exists(path) and not os.path.isdir(path):
        raise UsageError(option, path, "exists and is not a folder: choose a folder path")
    existing = os.path.abspath(path)
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing) or not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(option, path, f"cannot write there ({existing} is not a writable folder)")


def _cmd_measure(args) -> int:
    from volcaustics.scenes import resolve_scene

    from volcaustics.reports.experiment.run import OUTPUT_FILES, plain, run_experiment, write_experiment

    _check_output_set(args.output, "-o", files=OUTPUT_FILES)
    scene = resolve_scene(args.scene)
    params = _approx_params(args)
    p = params.resolved(scene)
    settings = _report_settings(args, width=p.width, height=p.height)
    experiment = run_experiment(scene, params, seeds=args.seeds, reference_settings=settings,
                                progress=not args.quiet)
    paths = write_experiment(experiment, args.output)
    s = plain(experiment.summary)  # NaN → None
    print(f"measure {scene.name}: {s['seeds']} seed(s), {s['experiment_seconds']['total']:.1f} s -> "
          f"{paths['summary.json']}")
    for component, m in s["images"].items():
        relmse, ratio, flip = m["relative_mse"], m["energy_ratio"], m["hdr_flip"]
        ci = f" [{100 * relmse['ci_low']:.2f}, {100 * relmse['ci_high']:.2f}]" if relmse["ci_low"] is not None else ""
        print(f"  {component:<9} relative MSE debiased {_pct(relmse['debiased'])}{ci}, "
              f"energy ratio {_num(ratio['value'])}, HDR-FLIP {_num(flip['value'])}")
    print("  caustic error decomposed: energy share of the reference ± SE, part of the relative MSE ± SE")
    for row in s["decomposition"]["rows"]:
        if row["term"] == "noise":
            print(f"    {'noise':<13} ±{100 * row['energy_sigma']:6.2f}%            {100 * row['relmse']:6.2f}%")
            continue
        print(f"    {row['term']:<13} {100 * row['energy_share']:+7.2f}% ± {100 * row['energy_share_se']:.2f}  "
              f"{100 * row['relmse_part']:+7.2f}% ± {100 * row['relmse_part_se']:.2f}")
    for warning in s["warnings"]:
        print(f"  warning: {warning}")
    return 0


def _budget(args) -> dict:
    """target_noise and its caps from the command line ("none" turns the target off)."""
    target = args.target_noise
    if target is not None and target.strip().lower() == "none":
        target = None
    return {"target_noise": target, "max_photons": args.max_photons, "max_seconds": args.max_seconds}


def _add_budget(p, *, target: str | None, max_seconds: float) -> None:
    p.add_argument("--target-noise", dest="target_noise", default=target, metavar="F",
                   help="render batches until every colour component's noise floor (sum var / sum mean^2 over "
                        "non-glass pixels) is at most F: a number (all components) or caustic=F,fog=F,direct=F; "
                        f"'none' renders exactly --batches (default: {target or 'none'})")
    p.add_argument("--max-photons", dest="max_photons", type=int, default=1 << 34,
                   help="photon cap of a --target-noise render (default 2^34)")
    p.add_argument("--max-seconds", dest="max_seconds", type=float, default=max_seconds,
                   help=f"time cap of a --target-noise render, seconds (default {max_seconds:g})")


def _cmd_sweep(args) -> int:
    from volcaustics.reports.core.executors import default_workers, parse_dask
    from volcaustics.reports.sweep.run import OUTPUT_FILES, OUTPUT_FOLDERS, SweepError, run_sweep, spec_from_args, spec_from_toml

    _check_output_set(args.output, "-o", files=OUTPUT_FILES, folders=OUTPUT_FOLDERS)
    if args.spec and (args.vary or args.set or args.scenes is not None):
        raise UsageError("SPEC.toml", args.spec, "give the grid in the file or on the command line, not both")
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers", args.workers, "expected at least 1 worker process")
    if args.dask:
        try:
            parse_dask(args.dask)
        except ValueError as exc:
            raise UsageError("--dask", args.dask, str(exc).split(": ", 1)[-1]) from None
    if args.spec:
        spec = spec_from_toml(args.spec)
    else:
        spec = spec_from_args(args.scenes, args.vary, args.set, preset=args.preset, seeds=args.seeds)
    result = run_sweep(spec, args.output, workers=args.workers or default_workers(), dask=args.dask,
                       progress=not args.quiet)
    print(f"sweep: {result.total} points: {result.done_before} already in the store, {result.computed} computed, "
          f"{len(result.failed)} failed, {result.seconds:.1f} s -> {args.output}/")
    suffice = result.tables.get("suffice")
    if suffice is not None and len(suffice):
        print(f"settings that suffice (error within {suffice['factor'].iloc[0]:g}x the best; caustic: debiased "
              f"relative MSE, intersection: the intersection term's own relative MSE):")
        for _, row in suffice.iterrows():
            print(f"  {row['scene']:<12} {row['layer_strategy']:<9} {row['parameter']:<12} "
                  f"{row['criterion'].split('_')[0]:<12} {row['suffices']:g} (of {row['largest']:g}): "
                  f"{100 * row['error']:.2f}% vs best {100 * row['best']:.2f}%, frame {row['frame_time_s']:.3f} s")
    for failure in result.failed:
        print(f"  failed: {failure['key'][:12]}: {failure['error']}", file=sys.stderr)
    return 1 if result.failed else 0


def _cmd_gate(args) -> int:
    from volcaustics.reports.gate.run import BASELINE, VERDICT, console_table, default_budgets_path, load_budgets, run_gate

    _check_output_set(args.out, "--out", files=(VERDICT,))
    if args.junit is not None:
        _check_output_file(args.junit, "--junit", ".xml")
    if args.update_baseline and not args.baseline:
        raise UsageError("--update-baseline", True, "needs --baseline DIR (where to write it)")
    if args.update_baseline:
        _check_output_set(args.baseline, "--baseline", files=(BASELINE,))
    overrides = _overrides(args.set)
    budgets = load_budgets(args.budgets or default_budgets_path())
    scenes = _scene_list(args.scenes, "--scenes")
    result = run_gate(budgets, overrides=overrides, baseline_dir=args.baseline, update_baseline=args.update_baseline,
                      out_dir=args.out, scenes=scenes, seeds=args.seeds, seed=args.seed,
                      render_references=args.render_references, junit=args.junit, progress=not args.quiet)
    print(console_table(result.checks))
    failed = sum(not c.passed for c in result.checks)
    verdict = "FAILED" if failed else "passed"
    print(f"gate {verdict}: {failed} of {len(result.checks)} checks failed, {result.seconds:.1f} s -> "
          f"{args.out}/{VERDICT}" + (f", {args.junit}" if args.junit else "")
          + (f"; baseline written: {result.updated_baseline}" if result.updated_baseline else ""))
    return result.exit_code


def _path(text: str) -> str:
    """An argparse type: a path, never the empty string (which would mean "not given")."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, not an empty string")
    return text


def _add_gate_inputs(p, *, scenes: str) -> None:
    """What the gate and the report measure and check: scenes, parameters over the
    budgets' preset, seeds, budgets and the baseline."""
    p.add_argument("--scenes", help=scenes)
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="an approximation parameter over the budgets' preset (repeatable)")
    p.add_argument("--seeds", type=int, help="frames per scene (default: the budgets' seeds, 4)")
    p.add_argument("--seed", type=int, default=0, help="the first seed (default 0)")
    p.add_argument("--budgets", type=_path, metavar="FILE.toml",
                   help="budgets per scene (default: reports/budgets.toml)")
    p.add_argument("--baseline", type=_path, metavar="DIR",
                   help="the last accepted results (DIR/baseline.json): also test for a regression against them")


def _add_report_reference(p) -> None:
    """The reference options of ``report`` and ``measure`` (default: the report's budget)."""
    from volcaustics.reports.core.sizing import REPORT_REFERENCE, REPORT_TARGET

    p.add_argument("--photons", type=int, default=REPORT_REFERENCE.photons,
                   help="reference photons over --batches batches: with the target, the size of a batch (default 2^22)")
    p.add_argument("--spp", type=int, default=REPORT_REFERENCE.spp,
                   help="reference camera samples per pixel over --batches batches (default 64)")
    p.add_argument("--batches", type=int, default=REPORT_REFERENCE.batches,
                   help="reference batches per stream, at least (default 16)")
    _add_budget(p, target=REPORT_TARGET, max_seconds=REPORT_REFERENCE.max_seconds)


def _report_settings(args, **size):
    from volcaustics.reference.settings import ReferenceSettings

    return ReferenceSettings(photons=args.photons, spp=args.spp, batches=args.batches, **size, **_budget(args))


def _cmd_export(args) -> int:
    from volcaustics.reference.render.export import export_xml
    from volcaustics.scenes import resolve_scene

    import os

    _check_output_file(args.mitsuba_xml, "--mitsuba-xml", ".xml")
    meshes = args.mitsuba_xml[: -len(".xml")] + "_meshes"
    if os.path.exists(meshes) and not os.path.isdir(meshes):
        raise UsageError("--mitsuba-xml", args.mitsuba_xml, f"{meshes} (where its meshes go) is a file: move it or "
                                                            f"choose another name")
    scene = resolve_scene(args.scene)
    export_xml(scene, args.mitsuba_xml)
    print(f"export {scene.name} -> {args.mitsuba_xml}")
    return 0


def _add_approx_params(p, default_preset: str = "paper"):
    g = p.add_argument_group("approximation parameters (DESIGN.md names; default: --preset)")
    g.add_argument("--preset", choices=("paper", "quick"), default=default_preset,
                   help="paper: photon_res 1500, layers 4, steps 4, iterations 30, peak_samples 8, scene image size; "
                        f"quick: 256x256, photon_res 256, light_res 256 (default {default_preset})")
    g.add_argument("--photon-res", dest="photon_res", type=int, help="photon map resolution N (N² texels)")
    g.add_argument("--layers", type=int, help="light-map levels (each: front + back map)")
    g.add_argument("--layer-strategy", dest="layer_strategy", choices=("threshold", "peel"))
    g.add_argument("--iterations", type=int, help="binary-search iterations")
    g.add_argument("--peak-samples", dest="peak_samples", type=int, help="samples to find the first sign change")
    g.add_argument("--steps", type=int, help="interaction steps (photon maps)")
    g.add_argument("--splat-radius", dest="splat_radius", type=float, help="Gaussian standard deviation (m)")
    g.add_argument("--light-res", dest="light_res", type=int, help="light map resolution")
    g.add_argument("--width", type=int, help="image width (default: the scene camera's)")
    g.add_argument("--height", type=int, help="image height (default: the scene camera's)")
    g.add_argument("--fog-steps", dest="fog_steps", type=int, help="ray-marching samples for fog")
    g.add_argument("--fresnel", choices=("deterministic", "stochastic"))
    g.add_argument("--seed", type=int, help="seed of the shared RNG")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="volcaustics", description=(
        "Validation harness for Real-time Volume Caustics with Image-based Photon Tracing: "
        "the paper's GPU method beside Mitsuba 3 ground truth."))
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("doctor", help="check GL, libLLVM and Mitsuba variants; exit 2 with the fix if unusable")
    p.set_defaults(func=_cmd_doctor)

    p = sub.add_parser("scenes", help="list the built-in scenes, or validate a scene file with --check")
    p.add_argument("--check", metavar="FILE.toml", help="validate a scene file: exit 0 and a summary, or exit 2 and the error")
    p.add_argument("--preview", metavar="DIR", help="also write a quick rasterised preview per scene (geometry, "
                                                     "framing, light cone; not physically based) as DIR/NAME.png")
    p.set_defaults(func=_cmd_scenes)

    p = sub.add_parser("approx", help="render SCENE with the paper's method: OUT.exr, .png, .records.npz, .json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml scene file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.exr", help="output EXR (siblings share its name)")
    p.add_argument("--records-max", dest="records_max", type=int, default=200_000,
                   help="segment records kept per step (fixed stride subsample; 0 none, -1 all; default 200000)")
    _add_approx_params(p)
    p.set_defaults(func=_cmd_approx)

    p = sub.add_parser("reference", help="ground truth of SCENE with Mitsuba 3 (cached): OUT.exr, .png, .json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml scene file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.exr", help="output EXR (mean and _var layers)")
    p.add_argument("--photons", type=int, default=1 << 24, help="light paths for the caustic (default 2^24)")
    p.add_argument("--spp", type=int, default=256, help="camera samples per pixel for fog/direct (default 256)")
    p.add_argument("--batches", type=int, default=8, help="independent batches for the variance (default 8)")
    p.add_argument("--max-scatter", dest="max_scatter", type=int, default=1,
                   help="scattering events per path (1 = single scattering, the paper's model)")
    p.add_argument("--width", type=int, help="image width (default: the scene camera's)")
    p.add_argument("--height", type=int, help="image height (default: the scene camera's)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--force", action="store_true", help="render even if the cache has this reference")
    _add_budget(p, target=None, max_seconds=600.0)
    p.set_defaults(func=_cmd_reference)

    p = sub.add_parser("export", help="write SCENE as a Mitsuba 3 XML file (with PLY meshes beside it)")
    p.add_argument("scene", metavar="SCENE")
    p.add_argument("--mitsuba-xml", dest="mitsuba_xml", required=True, metavar="OUT.xml")
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser("measure", help="one experiment on SCENE: approximation vs reference, exact replay, all "
                                       "metrics -> DIR/{segments,photons,images}.{parquet,csv}, decomposition.exr, "
                                       "summary.json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml scene file")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--seeds", type=int, default=4,
                   help="frames with seeds --seed … --seed + N − 1: the approximation's own noise needs N ≥ 2, "
                        "intervals N ≥ 4 (default 4)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_approx_params(p, default_preset="quick")
    _add_report_reference(p)
    p.set_defaults(func=_cmd_measure)

    p = sub.add_parser("sweep", help="a grid of experiments over approximation parameters, resumable, on local "
                                     "processes or Dask -> DIR (store, tables, figures)")
    p.add_argument("spec", nargs="?", metavar="SPEC.toml", help="the sweep as a TOML file (else the options below)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="the store folder (resumed when it exists)")
    p.add_argument("--scenes", help="comma-separated SCENE arguments (default: every built-in)")
    p.add_argument("--vary", action="append", metavar="NAME=V1,V2,...", help="a grid axis (repeatable)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="a fixed parameter (repeatable)")
    p.add_argument("--preset", choices=("quick", "paper"), default="quick", help="the parameters not named (default quick)")
    p.add_argument("--seeds", type=int, default=1, help="seeds per point (default 1)")
    p.add_argument("--workers", type=int, help="local worker processes (default: the core count)")
    p.add_argument("--dask", metavar="tcp://HOST:PORT|local:N",
                   help="run on Dask distributed: a running scheduler, or a LocalCluster of N process workers")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("gate", help="fail (exit 1) when the approximation exceeds its budgets or regresses against "
                                    "the baseline; exit 2 on bad input or missing data")
    _add_gate_inputs(p, scenes="comma-separated budgeted scenes (default: all in the budgets)")
    p.add_argument("--update-baseline", dest="update_baseline", action="store_true",
                   help="accept this run's results as the baseline (written atomically), no regression test")
    p.add_argument("--junit", metavar="OUT.xml", help="also write a JUnit XML report")
    p.add_argument("--out", default="runs/gate", help="gate.json and failure images (default runs/gate)")
    p.add_argument("--render-references", dest="render_references", action="store_true",
                   help="render missing references (else a missing one is an error, exit 2)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_gate)

    p = sub.add_parser("report", help="the main job: the accuracy report (one HTML page + summary.json) of the "
                                      "approximation against ground truth, with the gate's verdicts")
    p.add_argument("--out", default="runs/report", help="output folder (default runs/report)")
    _add_gate_inputs(p, scenes="comma-separated SCENE arguments (default: every built-in)")
    p.add_argument("--sweep", type=_path, metavar="DIR", help="add a sweep store's figures and settings that suffice")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    _add_report_reference(p)
    p.set_defaults(func=_cmd_report)
    return parser


def _interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` is Ctrl-C as Dr.Jit/Mitsuba pass it on: a KeyboardInterrupt raised
    in Python code that C++ called (an integrator's method, a symbolic loop's body)
    comes back as a RuntimeError naming it or chained to it."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, KeyboardInterrupt) or "KeyboardInterrupt" in str(exc):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def main(argv=None) -> int:
    """Run the command; exit 130 whenever Ctrl-C came, also during the imports and when
    Python dropped the KeyboardInterrupt ("Exception ignored in ...": raised inside a
    finalizer or weakref callback)."""
    import signal

    came = []

    def on_sigint(signum, frame):
        came.append(signum)
        signal.default_int_handler(signum, frame)

    previous = None
    try:
        if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:  # ignored (nohup, `cmd &`): leave it so
            previous = signal.signal(signal.SIGINT, on_sigint)
    except ValueError:  # not the main thread: signals are not ours to handle
        pass
    try:
        code = _run(argv)
    except KeyboardInterrupt:
        code = None
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    if code is None or (came and code != 130):
        print("volcaustics: interrupted", file=sys.stderr)
        return 130
    return code


def _run(argv) -> int | None:
    """The command's exit code; None when it was interrupted."""
    from volcaustics.approx.params import ParamError
    from volcaustics.reference.mi_setup import VariantError
    from volcaustics.reference.settings import SettingsError
    from volcaustics.scenes import SceneError

    from volcaustics.reports.page.collect import ReportError
    from volcaustics.reports.core.executors import ExecutorError
    from volcaustics.reports.experiment.run import ExperimentError
    from volcaustics.reports.gate.run import GateError
    from volcaustics.reports.sweep.run import SweepError

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (SceneError, ParamError, SettingsError, UsageError, ExperimentError, SweepError, GateError,
            ExecutorError, ReportError, VariantError) as exc:
        print(f"volcaustics: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except RuntimeError as exc:
        if not _interrupted(exc):
            raise
        return None
    except BrokenPipeError:  # output piped into `head` and closed: not an error of ours
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a file or folder the checks up front could not foresee (disk full, permissions)
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"volcaustics: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
