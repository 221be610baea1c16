"""The main job's report. Today it renders what exists: the built-in catalogue
(triangle counts, scene hashes) and a rasterised preview of every scene from its
camera; the accuracy report replaces the previews as the renderers land."""

from __future__ import annotations

import html
import json
import os
import time

from scenes.storage import atomic_write_text

from scenes.imageio import write_png


def build_report(out_dir: str, scene_names, *, width: int = 384, height: int = 384, progress: bool = True) -> dict:
    """Write ``index.html``, ``summary.json`` and ``previews/<scene>.png`` under ``out_dir``.

    Returns the summary (also written as JSON), including the parameters used.
    """
    from tqdm import tqdm

    from approx.context import gl_info, shared_context
    from approx.preview import render_preview
    from scenes import load_builtin

    ctx = shared_context()
    rows = []
    for name in tqdm(scene_names, desc="report", unit="scene", disable=not progress):
        t0 = time.perf_counter()
        scene = load_builtin(name)
        image = render_preview(ctx, scene, width, height)
        preview = os.path.join("previews", f"{name}.png")
        write_png(os.path.join(out_dir, preview), image)
        rows.append({"scene": name, "description": scene.description,
                     "specular_triangles": scene.specular_triangle_count(),
                     "scene_hash": scene.scene_hash(), "preview": preview,
                     "seconds": round(time.perf_counter() - t0, 3)})
    summary = {"kind": "catalogue preview", "gl": gl_info(ctx), "params": {"width": width, "height": height},
               "scenes": rows}
    atomic_write_text(os.path.join(out_dir, "summary.json"), json.dumps(summary, indent=2))
    atomic_write_text(os.path.join(out_dir, "index.html"), _html(summary))
    return summary


def _html(summary: dict) -> str:
    cells = "\n".join(
        f"<tr><td><b>{html.escape(r['scene'])}</b></td><td>{r['specular_triangles']:,}</td>"
        f"<td>{html.escape(r['description'])}</td><td><code>{r['scene_hash'][:12]}</code></td>"
        f"<td><img src='{html.escape(r['preview'])}' width=192></td></tr>"
        for r in summary["scenes"])
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>volcaustics report</title>
<style>body{{font-family:sans-serif;margin:2em}} td,th{{padding:4px 10px;text-align:left;vertical-align:middle}}</style>
</head><body>
<h1>volcaustics — built-in scenes</h1>
<p>Rasterised previews (not physically based) from each scene's camera; GL: {html.escape(summary['gl']['renderer'])}.
The accuracy report (approx vs reference) replaces this page as the renderers land.</p>
<table><tr><th>scene</th><th>specular triangles</th><th>description</th><th>scene_hash</th><th>preview</th></tr>
{cells}
</table></body></html>
"""
