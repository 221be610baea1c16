"""``volcaustics scenes``: list the built-in scenes, validate a scene file, previews."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from volcaustics.reports.measuring.results.output_folders import check_output_dir

if TYPE_CHECKING:
    import argparse


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("scenes", help="list the built-in scenes, or validate a scene file with --check")
    p.add_argument("--check", metavar="FILE.toml",
                   help="validate a scene file: exit 0 and a summary, or exit 2 and the error")
    p.add_argument("--preview", metavar="DIR", help="also write a quick rasterised preview per scene (geometry, "
                                                     "framing, light cone; not physically based) as DIR/NAME.png")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.scenes import BUILTIN_NAMES, load_builtin, load_scene, resolve_scene
    from volcaustics.scenes.catalogue import MEDIA_NAMES

    if args.preview is not None:
        check_output_dir(args.preview, "--preview")
    if args.check:
        scene = load_scene(args.check)
        tris = scene.specular_triangle_count()
        print(f"ok: {args.check}: scene '{scene.name}', {len(scene.specular)} specular object(s) "
              f"({tris:,} triangles), {len(scene.diffuse)} diffuse, scene_hash {scene.scene_hash()[:12]}"
              + (f", animation of {scene.animation.frames} frames ({', '.join(t.path for t in scene.animation.tracks)})"
                 if scene.animation else ""))
        if args.preview:
            print(f"preview -> {_write_preview(scene, args.preview)}")
        return 0
    print(f"{'name':<12} {'triangles':>10}  description")
    for name in (*BUILTIN_NAMES, *MEDIA_NAMES):
        scene = load_builtin(name) if name in BUILTIN_NAMES else resolve_scene(name)
        animated = f" [animation: {scene.animation.frames} frames]" if scene.animation else ""
        medium = " [heterogeneous medium: make report-media]" if name in MEDIA_NAMES else ""
        print(f"{name:<12} {scene.specular_triangle_count():>10,}  {scene.description}{animated}{medium}")
        if args.preview:
            _write_preview(scene, args.preview)
    if args.preview:
        print(f"previews -> {args.preview}/")
    return 0


def _write_preview(scene, folder: str) -> str:
    from volcaustics.approx.context import shared_context
    from volcaustics.approx.preview import render_preview
    from volcaustics.infra.imageio import write_png

    path = os.path.join(folder, f"{scene.name}.png")
    write_png(path, render_preview(shared_context(), scene))
    return path
