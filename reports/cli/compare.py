"""``volcaustics compare SCENE IMAGE.exr [IMAGE2.exr …] -o DIR``: another renderer's
images against the reference, measured as the approximation is."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import UsageError, add_report_reference, debiased, known, num, report_settings
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
    from volcaustics.reports.studies.compare.comparison_read import ComparedRenderer
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
    compared = ComparedRenderer.from_summary(plain(comparison.summary), os.path.abspath(args.output),
                                             comparison.views)
    row = comparison_row(compared)
    paths = write_comparison(comparison, args.output, comparison_page(row, comparison_images(row, comparison.views)))
    print(f"compare {name} on {scene.name}: {compared.seeds} file(s) at {compared.width}x{compared.height}, "
          f"{compared.compared_pixels:,} pixels compared, {(compared.seconds or {})['total']:.1f} s "
          f"-> {paths['summary.json']}")
    for component in compared.components:
        relmse, ratio = compared.metric("relative_mse", component), compared.metric("energy_ratio", component)
        mean = debiased(known(relmse.debiased), low=known(relmse.ci_low), high=known(relmse.ci_high))
        flip = compared.metric("hdr_flip", component).value
        print(f"  {component:<9} relative MSE debiased {mean}, energy ratio {num(known(ratio.value))}, "
              f"HDR-FLIP {num(known(flip))}")
    for warning in compared.warnings:
        print(f"  warning: {warning}")
    return 0
