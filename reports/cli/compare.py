"""``volcaustics compare SCENE IMAGE.exr [IMAGE2.exr …] -o DIR``: another renderer's
images against the reference, measured as the approximation is."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import UsageError, add_report_reference, debiased, num, report_settings
from volcaustics.reports.measuring.results.output_folders import check_output_set

if TYPE_CHECKING:
    import argparse

# native extensions loaded at start-up, with Ctrl-C held (cli.main)
NATIVE = ("drjit", "mitsuba")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("compare", help="another renderer's EXRs of SCENE against the reference: the image metrics, "
                                       "noise debiasing and error maps the approximation gets -> DIR/images.parquet, "
                                       "views.exr, index.html, summary.json")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml scene file")
    p.add_argument("images", nargs="+", metavar="IMAGE.exr",
                   help="one OpenEXR file per seed: layers caustic, fog, direct (channels caustic.R, …; optional "
                        "combined, mask_specular) or root R, G, B (compared as combined); linear radiance, box filter")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--name", default=None,
                   help="the renderer's name on tables and pages (default: the first image's file stem)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_report_reference(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.reports.measuring.results.tables import plain
    from volcaustics.reports.presenting.page.external import comparison_images, comparison_page, comparison_row
    from volcaustics.reports.studies.compare.comparison_run import KIND, run_compare
    from volcaustics.reports.studies.compare.comparison_write import OUTPUT_FILES, write_comparison
    from volcaustics.scenes import resolve_scene

    check_output_set(args.output, "-o", files=OUTPUT_FILES, kind=KIND)
    name = args.name if args.name is not None else os.path.splitext(os.path.basename(args.images[0]))[0]
    if not name.strip():
        raise UsageError("--name", args.name, "expected a non-empty name for the renderer")
    scene = resolve_scene(args.scene)
    comparison = run_compare(scene, args.images, name=name, reference_settings=report_settings(args),
                             progress=not args.quiet)
    loaded = {"folder": os.path.abspath(args.output), "summary": plain(comparison.summary), "views": comparison.views}
    row = comparison_row(loaded)
    paths = write_comparison(comparison, args.output, comparison_page(row, comparison_images(row, comparison.views)))
    s = loaded["summary"]
    print(f"compare {name} on {scene.name}: {s['seeds']} file(s) at {s['width']}x{s['height']}, "
          f"{s['compared_pixels']:,} pixels compared, {s['seconds']['total']:.1f} s -> {paths['summary.json']}")
    for component, m in s["images"].items():
        relmse, ratio, flip = m["relative_mse"], m["energy_ratio"], m["hdr_flip"]
        mean = debiased(relmse["debiased"], low=relmse["ci_low"], high=relmse["ci_high"])
        print(f"  {component:<9} relative MSE debiased {mean}, "
              f"energy ratio {num(ratio['value'])}, HDR-FLIP {num(flip['value'])}")
    for warning in s["warnings"]:
        print(f"  warning: {warning}")
    return 0
