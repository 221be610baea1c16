"""Two renderers judged by ``compare``, per scene: stock Mitsuba 3 (``volpath``,
max_depth 2, from the scene's exported XML; root R, G, B only, so compared as
``combined``) and the paper's method at the paper preset (``approx`` EXRs with every
layer), each with ``--seeds`` files, against the report's reference at that size.

    .venv/bin/python bench/compare_external.py [SCENE ...] [--size 256] [--seeds 4] [--spp 64]

Stock volpath cannot reach the medium through glass from a delta light (the XML's
comment says why), so its combined image lacks the volume caustic: its energy ratio
says how much of the frame that is. Prints per renderer the seconds to render its files,
``export``'s seconds (XML and glTF), ``compare``'s (reference from the cache or rendered
to the report's targets, then the metrics) and the headline numbers. Files go to
``--out`` (default runs/bench-compare/SCENE/).
"""

from __future__ import annotations

import argparse
import os
import sys
import time


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=["refocus", "bunny"])
    parser.add_argument("--size", type=int, default=256, help="image width and height (default 256)")
    parser.add_argument("--seeds", type=int, default=4, help="files per renderer (default 4)")
    parser.add_argument("--spp", type=int, default=64, help="volpath samples per pixel per file (default 64)")
    parser.add_argument("--out", default="runs/bench-compare")
    args = parser.parse_args(argv)

    from volcaustics.experiment.sizing import REPORT_REFERENCE
    from volcaustics.scenes import resolve_scene

    print(f"{'scene':10} {'renderer':16} {'render s':>9} {'compare s':>10} {'ref s':>7}  "
          f"{'caustic relMSE':>15} {'combined relMSE':>16} {'combined energy':>16}")
    for name in args.scenes:
        scene = resolve_scene(name)
        folder = os.path.join(args.out, scene.name)
        os.makedirs(folder, exist_ok=True)
        seconds = {"export": _export(scene, folder)}
        shots = {"mitsuba-volpath": _volpath(scene, folder, args, seconds),
                 "approx-paper": _approx(scene, folder, args, seconds)}
        for renderer, paths in shots.items():
            _compare(scene, renderer, paths, folder, REPORT_REFERENCE, seconds)
        print(f"{scene.name:10} export: XML + glTF {seconds['export']:.2f} s", flush=True)
    return 0


def _export(scene, folder: str) -> float:
    from volcaustics.reference.render.export import export_xml
    from volcaustics.reports.presenting.exports.gltf import export_gltf

    t0 = time.perf_counter()
    export_xml(scene, os.path.join(folder, "scene.xml"))
    export_gltf(scene, os.path.join(folder, "scene.glb"))
    return time.perf_counter() - t0


def _volpath(scene, folder: str, args, seconds: dict) -> list:
    """Stock Mitsuba on the exported XML, one EXR (root R, G, B) per seed."""
    from volcaustics.reference.mi_setup import mitsuba

    mi = mitsuba()
    t0 = time.perf_counter()
    loaded = mi.load_file(os.path.join(folder, "scene.xml"), resx=args.size, resy=args.size, spp=args.spp)
    paths = []
    for seed in range(args.seeds):
        image = mi.render(loaded, seed=seed, spp=args.spp)
        path = os.path.join(folder, f"volpath-{seed}.exr")
        mi.Bitmap(image).write(path)
        paths.append(path)
    seconds["mitsuba-volpath"] = time.perf_counter() - t0
    return paths


def _approx(scene, folder: str, args, seconds: dict) -> list:
    """The paper's method, paper preset, through ``volcaustics approx``'s own writer."""
    import dataclasses

    from volcaustics.approx.params import PAPER
    from volcaustics.reports.presenting.exports.approx_files import run_approx

    t0 = time.perf_counter()
    paths = []
    for seed in range(args.seeds):
        params = dataclasses.replace(PAPER, width=args.size, height=args.size, seed=seed)
        path = os.path.join(folder, f"approx-{seed}.exr")
        run_approx(scene, params, path, records_max=0)
        paths.append(path)
    seconds["approx-paper"] = time.perf_counter() - t0
    return paths


def _compare(scene, renderer: str, paths: list, folder: str, settings, seconds: dict) -> None:
    from volcaustics.reports.studies.compare.comparison_run import run_compare

    t0 = time.perf_counter()
    comparison = run_compare(scene, paths, name=renderer, reference_settings=settings, progress=False)
    total = time.perf_counter() - t0
    s = comparison.summary
    images = s["images"]

    def relmse(component):
        m = images.get(component, {}).get("relative_mse")
        return f"{100 * m['debiased']:.2f}%" if m else "–"

    print(f"{scene.name:10} {renderer:16} {seconds[renderer]:>9.1f} {total:>10.1f} {s['seconds']['reference']:>7.1f}  "
          f"{relmse('caustic'):>15} {relmse('combined'):>16} {images['combined']['energy_ratio']['value']:>16.3f}",
          flush=True)
    for warning in s["warnings"]:
        print(f"{'':28}warning: {warning}")


if __name__ == "__main__":
    sys.exit(main())
