"""The main job's report: every built-in scene rendered by both renderers, side by
side, with the error of the approximation per component.

It renders what exists today — the approximation (``--preset quick`` sizes by
default) and the cached ground truth at the same image size — and measures, over
the pixels that do not see glass (``mask_specular``), each component's relative
MSE (Σ(a − r)² / Σ r²) and energy ratio (Σ a / Σ r). Later work extends it into
the full accuracy report (intersection errors, sweeps, gate).
"""

from __future__ import annotations

import dataclasses
import html
import json
import os
import time

import numpy as np

from scenes.formats import COLOUR_LAYERS, MASK_LAYER
from scenes.imageio import write_png
from scenes.storage import atomic_write_text


def scene_errors(approx_images: dict, reference_mean: dict) -> dict:
    """Per layer: relative MSE and energy ratio of the approximation over non-glass pixels."""
    from metrics.image import relative_mse

    keep = reference_mean[MASK_LAYER][..., 0] < 0.5
    out = {}
    for layer in COLOUR_LAYERS:
        a, r = approx_images[layer], reference_mean[layer]
        energy = float(r[keep].sum())
        out[layer] = {"relative_mse": relative_mse(r, a, mask=keep) if energy > 0 else None,
                      "energy_ratio": float(a[keep].sum()) / energy if energy > 0 else None}
    return out


def build_report(out_dir: str, scene_names, *, width: int = 256, height: int = 256, approx_params=None,
                 reference_settings=None, progress: bool = True) -> dict:
    """Render, measure and write ``index.html``, ``summary.json`` and ``images/`` under ``out_dir``.

    Returns the summary (also written as JSON), including the parameters used.
    """
    from tqdm import tqdm

    from approx import Renderer
    from approx.context import gl_info, shared_context
    from approx.params import QUICK
    from reference.render import render_reference
    from scenes import load_builtin

    from .defaults import REPORT_REFERENCE

    approx_params = dataclasses.replace(approx_params or QUICK, width=width, height=height)
    reference_settings = dataclasses.replace(
        reference_settings or REPORT_REFERENCE, width=width, height=height)
    rows = []
    for name in tqdm(scene_names, desc="report", unit="scene", disable=not progress):
        scene = load_builtin(name)  # the image size is in approx_params and reference_settings only
        t0 = time.perf_counter()
        renderer = Renderer(scene)
        renderer.render(approx_params, keep_records=False)  # compile shaders; time the second frame
        frame = renderer.render(approx_params, keep_records=False)
        renderer.release()
        reference = render_reference(scene, reference_settings, progress=progress)
        ref = reference.mean
        exposure = 1.0 / max(float(np.percentile(ref["combined"][ref["combined"] > 0], 99.5)), 1e-12) \
            if (ref["combined"] > 0).any() else 1.0
        images = {}
        for label, image in (("approx_combined", frame.images["combined"]), ("reference_combined", ref["combined"]),
                             ("approx_caustic", frame.images["caustic"]), ("reference_caustic", ref["caustic"]),
                             ("error_combined", np.abs(frame.images["combined"] - ref["combined"]))):
            rel = os.path.join("images", f"{name}_{label}.png")
            write_png(os.path.join(out_dir, rel), image, exposure=exposure)
            images[label] = rel
        rows.append({"scene": name, "description": scene.description,
                     "specular_triangles": scene.specular_triangle_count(), "scene_hash": scene.scene_hash(),
                     "errors": scene_errors(frame.images, ref), "approx_timings_s": frame.timings,
                     "approx_timing_method": frame.timing_method, "reference": reference.manifest,
                     "images": images, "seconds": round(time.perf_counter() - t0, 3)})
    summary = {"kind": "approx vs reference", "gl": gl_info(shared_context()),
               "approx_params": approx_params.to_dict(), "reference_settings": reference_settings.to_dict(),
               "scenes": rows}
    atomic_write_text(os.path.join(out_dir, "summary.json"), json.dumps(summary, indent=2, default=float))
    atomic_write_text(os.path.join(out_dir, "index.html"), _html(summary))
    return summary


def _floors(floors: dict) -> str:
    return ", ".join(f"{name} {100 * v:.3f}%" for name, v in floors.items() if v is not None)


def _fmt(x, pct=False):
    if x is None:
        return "–"
    return f"{100 * x:.2f}%" if pct else f"{x:.3f}"


def _html(summary: dict) -> str:
    blocks = []
    for r in summary["scenes"]:
        e = r["errors"]
        table = "".join(
            f"<tr><td>{layer}</td><td>{_fmt(e[layer]['relative_mse'], pct=True)}</td>"
            f"<td>{_fmt(e[layer]['energy_ratio'])}</td></tr>" for layer in COLOUR_LAYERS)
        imgs = "".join(f"<figure><img src='{html.escape(path)}' width=256><figcaption>{html.escape(label)}"
                       f"</figcaption></figure>" for label, path in r["images"].items())
        t = r["approx_timings_s"]
        blocks.append(
            f"<section id='{html.escape(r['scene'])}'><h2>{html.escape(r['scene'])}</h2>"
            f"<p>{html.escape(r['description'])} — {r['specular_triangles']:,} specular triangles, "
            f"scene_hash <code>{r['scene_hash'][:12]}</code></p>"
            f"<div class='imgs'>{imgs}</div>"
            f"<table><tr><th>layer</th><th>relative MSE</th><th>energy ratio (approx / reference)</th></tr>{table}</table>"
            f"<p>approx frame {t['frame_wall']:.3f} s ({html.escape(r['approx_timing_method'])}): trace "
            f"{t['trace']:.3f} s, splat {t['splat']:.3f} s. Reference: {r['reference']['photons']:,} photons, "
            f"{r['reference']['batches']} + {r['reference']['camera_batches']} batches, "
            f"{html.escape(r['reference']['mitsuba_variant'])}{' (cached)' if r['reference']['cached'] else ''}; "
            f"noise floor {html.escape(_floors(r['reference']['noise_floor']))} "
            f"(stopped by {html.escape(r['reference']['stopped_by'])}).</p></section>")
    params = html.escape(json.dumps(summary["approx_params"]))
    ref = html.escape(json.dumps(summary["reference_settings"]))
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>volcaustics report</title>
<style>body{{font-family:sans-serif;margin:2em;max-width:1400px}} td,th{{padding:3px 10px;text-align:left}}
.imgs{{display:flex;flex-wrap:wrap;gap:8px}} figure{{margin:0}} figcaption{{font-size:80%}}</style>
</head><body>
<h1>volcaustics — approximation vs ground truth</h1>
<p>GL: {html.escape(summary['gl']['renderer'])}. Errors over pixels that do not see glass. Images share the
reference's exposure; <i>error_combined</i> is |approx − reference|.</p>
<p>approx parameters: <code>{params}</code><br>reference settings: <code>{ref}</code></p>
{''.join(blocks)}
</body></html>
"""
