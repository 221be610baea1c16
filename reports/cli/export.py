"""``volcaustics export SCENE [--mitsuba-xml OUT.xml] [--gltf OUT.glb|OUT.gltf]``: the
scene for Mitsuba 3 itself and for real-time engines (glTF 2.0); at least one."""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcaustics.reports.cli.common import UsageError
from volcaustics.reports.measuring.results.output_folders import check_output_file

if TYPE_CHECKING:
    import argparse


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("export", help="write SCENE as a Mitsuba 3 XML file (with PLY meshes beside it) and/or as "
                                      "glTF 2.0 (.glb, or .gltf with a .bin beside it)")
    p.add_argument("scene", metavar="SCENE")
    p.add_argument("--mitsuba-xml", dest="mitsuba_xml", metavar="OUT.xml",
                   help="the scene for Mitsuba 3 (meshes in OUT_meshes/)")
    p.add_argument("--gltf", metavar="OUT.glb|OUT.gltf",
                   help="the scene at rest as glTF 2.0 (spot light, glass, camera; the medium and the exact spot "
                        "falloff in extras): one .glb, or OUT.gltf with OUT.bin")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.reference.render.export import export_xml, mesh_folder_problem
    from volcaustics.reports.presenting.exports.gltf import DENSITY_SUFFIX, FORMATS, export_gltf
    from volcaustics.scenes import resolve_scene

    if args.mitsuba_xml is None and args.gltf is None:
        raise UsageError("--mitsuba-xml / --gltf", None, "name at least one output: --mitsuba-xml OUT.xml, "
                                                         "--gltf OUT.glb|OUT.gltf, or both")
    if args.mitsuba_xml is not None:
        check_output_file(args.mitsuba_xml, "--mitsuba-xml", ".xml")
        problem = mesh_folder_problem(args.mitsuba_xml)
        if problem is not None:
            raise UsageError("--mitsuba-xml", args.mitsuba_xml, problem)
    if args.gltf is not None:
        ext = next((e for e in FORMATS if args.gltf.lower().endswith(e)), None)
        if ext is None:
            raise UsageError("--gltf", args.gltf, "expected a file name ending in .glb (one binary file) or .gltf "
                                                  "(with a .bin of the same stem beside it), e.g. out.glb")
        check_output_file(args.gltf, "--gltf", ext, siblings=(".bin",) if ext == ".gltf" else ())
    scene = resolve_scene(args.scene)
    if args.mitsuba_xml is not None:
        export_xml(scene, args.mitsuba_xml)
        print(f"export {scene.name} -> {args.mitsuba_xml}")
    if args.gltf is not None:
        done = export_gltf(scene, args.gltf)
        print(f"export {scene.name} -> {done['files'][0]} (glTF 2.0: {done['nodes']} nodes, {done['meshes']} meshes, "
              f"{done['triangles']} triangles, {done['vertices']} vertices)")
        for extra in done["files"][1:]:
            what = ("the medium's density grid" if extra.endswith(DENSITY_SUFFIX) else
                    f"its buffer, {done['bytes']} bytes")
            print(f"export {scene.name} -> {extra} ({what})")
    return 0
