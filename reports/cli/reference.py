"""``volcaustics reference SCENE -o OUT.exr``: ground truth from Mitsuba 3 (cached)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import add_budget, budget
from volcaustics.reports.measuring.results.output_folders import check_output_file

if TYPE_CHECKING:
    import argparse

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("drjit", "mitsuba")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("reference", help="ground truth of SCENE with Mitsuba 3 (cached): OUT.exr, .png, .json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml scene file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.exr", help="output EXR (mean and _var layers)")
    p.add_argument("--photons", type=int, default=1 << 24, help="light paths for the caustic (default 2^24)")
    p.add_argument("--spp", type=int, default=256, help="camera samples per pixel for fog/direct (default 256)")
    p.add_argument("--batches", type=int, default=8, help="independent batches for the variance (default 8)")
    p.add_argument("--max-scatter", dest="max_scatter", type=int, default=1,
                   help="scattering orders K (1 = single scattering, the paper's model; K > 1 adds the layers "
                        "<component>_ms: what orders 2..K add, the model term)")
    p.add_argument("--width", type=int, help="image width (default: the scene camera's)")
    p.add_argument("--height", type=int, help="image height (default: the scene camera's)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--force", action="store_true", help="render even if the cache has this reference")
    add_budget(p, target=None, max_seconds=600.0)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.reference.served import describe_budget
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.reports.presenting.exports.reference_files import run_reference
    from volcaustics.scenes import resolve_scene

    check_output_file(args.output, "-o", ".exr", (".png", ".json"))
    scene = resolve_scene(args.scene)
    settings = ReferenceSettings(photons=args.photons, spp=args.spp, batches=args.batches,
                                 max_scatter=args.max_scatter, width=args.width, height=args.height, seed=args.seed,
                                 **budget(args))
    summary = run_reference(scene, settings, args.output, force=args.force)
    source = "cache" if summary["cached"] else f"rendered in {summary['seconds_this_call']:.1f} s"
    floors = ", ".join(f"{k} {100 * v:.3f}%" for k, v in summary["noise_floor"].items() if v is not None)
    orders = (f" + {summary['orders_batches']} of {summary['max_scatter']} scattering orders"
              if summary.get("orders_batches") else "")
    served = summary["served_to"]  # judged against this request (reference.served)
    other = ("" if served["rendered_for"] is None else
             f"; rendered for another request: {describe_budget(served['rendered_for'])}")
    print(f"reference {scene.name}: {summary['photons']:,} photons, {summary['batches']} + "
          f"{summary['camera_batches']}{orders} batches ({source}, {summary['mitsuba_variant']}; stopped by "
          f"{served['stopped_by']}{other}); noise floor {floors} -> {summary['outputs']['exr']}")
    return 0
