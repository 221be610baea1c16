"""``volcaustics approx SCENE -o OUT.exr``: one frame of the paper's method and its files."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import UsageError
from volcaustics.reports.measuring.results.output_folders import check_output_file
from volcaustics.reports.measuring.results.param_input import add_param_flags, params_from_args, preset_size_note

if TYPE_CHECKING:
    import argparse

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("moderngl",)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("approx", help="render SCENE with the paper's method: OUT.exr, .png, .records.npz, .json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml scene file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.exr", help="output EXR (siblings share its name)")
    p.add_argument("--records-max", dest="records_max", type=int, default=200_000,
                   help="segment records kept per step (fixed stride subsample; 0 none, -1 all; default 200000)")
    add_param_flags(p, default_preset="paper")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.experiment.point_checks import check_denoiser
    from volcaustics.reports.measuring.cost_match import with_auto_values
    from volcaustics.reports.presenting.exports.approx_files import run_approx
    from volcaustics.scenes import resolve_scene

    check_output_file(args.output, "-o", ".exr", (".png", ".json", ".records.npz"))
    if args.records_max < -1:
        raise UsageError("--records-max", args.records_max, "expected 0 (none), -1 (all) or a positive count")
    scene = resolve_scene(args.scene)
    check_denoiser(params_from_args(args))  # before the cost match renders
    params = with_auto_values(args.scene, params_from_args(args), args.preset, args.photon_res is not None,
                              layers_given=args.layers is not None)
    note = preset_size_note(args, params, scene)
    if note:
        print(f"approx: {note}", file=sys.stderr)
    frame, outputs = run_approx(scene, params, args.output, records_max=args.records_max)
    t = frame.timings
    print(f"approx {scene.name}: {t['frame_wall']:.2f} s ({frame.timing_method}), "
          f"trace {t['trace']:.2f} s, splat {t['splat']:.2f} s -> {outputs['exr']}")
    return 0
