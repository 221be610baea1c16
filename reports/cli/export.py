"""``volcaustics export SCENE --mitsuba-xml OUT.xml``: the scene for Mitsuba 3 itself."""

from __future__ import annotations

import os

from volcaustics.reference.render.export import export_xml
from volcaustics.reports.cli.common import UsageError, check_output_file
from volcaustics.scenes import resolve_scene


def register(sub) -> None:
    p = sub.add_parser("export", help="write SCENE as a Mitsuba 3 XML file (with PLY meshes beside it)")
    p.add_argument("scene", metavar="SCENE")
    p.add_argument("--mitsuba-xml", dest="mitsuba_xml", required=True, metavar="OUT.xml")
    p.set_defaults(func=run)


def run(args) -> int:
    check_output_file(args.mitsuba_xml, "--mitsuba-xml", ".xml")
    meshes = args.mitsuba_xml[: -len(".xml")] + "_meshes"
    if os.path.exists(meshes) and not os.path.isdir(meshes):
        raise UsageError("--mitsuba-xml", args.mitsuba_xml, f"{meshes} (where its meshes go) is a file: move it or "
                                                            f"choose another name")
    scene = resolve_scene(args.scene)
    export_xml(scene, args.mitsuba_xml)
    print(f"export {scene.name} -> {args.mitsuba_xml}")
    return 0
