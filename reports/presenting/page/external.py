"""Other renderers on the page (``volcaustics compare``): one renderer's section — its
numbers per component, its images beside the reference's, its error maps on the
report's fixed scales — drawn into ``compare``'s own ``index.html`` and, with
``report --compare NAME=DIR``, into each scene of the accuracy report, with one row
per renderer beside the approximation in the overview's "Renderers" table."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from html import escape
from typing import TYPE_CHECKING

from volcaustics.experiment.versions import code_version
from volcaustics.reports.presenting.page.data_uris import SCALES, colour_bar_css, component_images, exposures
from volcaustics.reports.presenting.page.parts import CSS, SCRIPT, debiased_pct
from volcaustics.reports.presenting.page.parts import colour_bar as _colour_bar
from volcaustics.reports.presenting.page.parts import figure as _figure
from volcaustics.reports.presenting.page.parts import num as _num
from volcaustics.reports.presenting.page.parts import pct as _pct
from volcaustics.reports.presenting.page.report_document import MISSING, ComponentErrors

if TYPE_CHECKING:
    from volcaustics.experiment.result import Estimate
    from volcaustics.reports.presenting.page.report_document import ScenePage
    from volcaustics.reports.studies.compare.comparison_read import ComparedRenderer

COLUMNS = ("relative_mse", "energy_ratio", "hdr_flip", "per_pixel_relative_mse")


def comparison_row(c: ComparedRenderer, name: str | None = None) -> dict:
    """What a report's summary.json keeps of one comparison (``compare.read.load_comparison``):
    the renderer's name (``name`` given to ``report --compare``, else its own), scene,
    size, seeds, components and their headline numbers, exposures, warnings."""
    def stored(metric: str, component: str) -> dict:
        found = c.find_metric(metric, component)
        return {} if found is None else found.to_json()

    return {"renderer": name or c.renderer, "scene": c.scene, "scene_hash": c.scene_hash,
            "folder": c.folder, "width": c.width, "height": c.height, "seeds": c.seeds,
            "components": list(c.components), "mask": c.mask, "reference": dict(c.reference),
            "compared_pixels": c.compared_pixels,
            "images": {comp: {m: stored(m, comp) for m in COLUMNS} for comp in c.components},
            "exposure": exposures(dict(c.views), list(c.components)), "warnings": list(c.warnings),
            "code_version": c.code_version, "stale": c.code_version != code_version(),
            "seconds": None if c.seconds is None else dict(c.seconds)}


def comparison_images(row: dict, views: dict) -> dict:
    """Data URIs of one comparison: renders at its exposures, error maps on the fixed scales."""
    return component_images(views, row["exposure"], "renderer")


def _component_table(row: dict) -> str:
    head = ("<tr><th class='l'>component</th><th>relative MSE, debiased [95%]</th><th>reference noise floor</th>"
            "<th>renderer's own noise</th><th>energy ratio [95%]</th><th>HDR-FLIP (mean)</th>"
            "<th>per-pixel relative MSE</th></tr>")
    body = []
    for component in row["components"]:
        m = row["images"][component]
        relmse, energy = m["relative_mse"], m["energy_ratio"]
        body.append(f"<tr class='compare-row' data-component='{component}'><td class='l'>{component}</td>"
                    f"<td>{debiased_pct(relmse.get('debiased'), low=relmse.get('ci_low'), high=relmse.get('ci_high'))}"
                    "</td>"
                    f"<td>{_pct(relmse.get('reference_floor'), 3)}</td><td>{_pct(relmse.get('approx_noise'), 3)}</td>"
                    f"<td>{_num(energy.get('value'), '{:.3f}')}"
                    + (f" [{_num(energy.get('ci_low'), '{:.3f}')}, {_num(energy.get('ci_high'), '{:.3f}')}]"
                       if energy.get("ci_low") is not None else "")
                    + f"</td><td>{_num(m['hdr_flip'].get('value'))}</td>"
                      f"<td>{_num(m['per_pixel_relative_mse'].get('value'))}</td></tr>")
    return f"<table class='compare-table'>{head}{''.join(body)}</table>"


def comparison_section(prefix: str, row: dict, images: dict) -> str:
    """One renderer's section (``prefix``: unique per page, for element ids)."""
    bars: dict[str, dict] = {name: {"css": colour_bar_css(scale), "ticks": scale.ticks()}
                             for name, scale in SCALES.items()}
    width = row["width"] * max(1, 256 // row["width"])  # small renders magnified, pixelated
    renders, maps = [], []
    for component in row["exposure"]:
        own, ref, label = f"{prefix}-renderer-{component}", f"{prefix}-reference-{component}", \
            f"{prefix}-renderer-{component}-label"
        name = escape(row["renderer"])
        renders.append("<div class='row'>" + _figure(
            images[f"renderer.{component}"], f"{name}, {component} (mean over its files) — <span id='{label}'>"
            f"showing: {name} (hover or click: reference)</span>", ident=own, cls="render swap", width=width,
            extra=f" data-other='{ref}' data-label='{label}' data-name='{name}'")
            + _figure(images[f"reference.{component}"], f"reference (Mitsuba 3), {component}", ident=ref,
                      width=width) + "</div>")
    for metric, scale in SCALES.items():
        items = [_figure(images.get(f"map.{metric}.{c}"), f"{escape(scale.label)}, {c}: the first file", width=width)
                 for c in row["exposure"]]
        items.append(f"<div>{_colour_bar({**scale.to_dict(), 'ticks': bars[metric]['ticks']}, bars[metric]['css'])}"
                     f"</div>")
        maps.append(f"<div class='row'>{''.join(items)}</div>")
    ref = row["reference"]
    floors = ", ".join(f"{k} {_pct(v, 3)}" for k, v in (ref.get("noise_floor") or {}).items())
    warnings = "".join(f"<li class='warn'>{escape(w)}</li>" for w in row["warnings"])
    stale = (f"<p class='warn'>Measured with other code (version {escape(str(row['code_version']))}): rerun "
             f"<code>volcaustics compare</code>.</p>" if row["stale"] else "")
    missing = [c for c in ("caustic", "fog", "direct") if c not in row["components"]]
    masks = "the files' mask_specular and the reference's" if row["mask"] == "file" else "the reference's mask"
    return f"""<div class='comparison' id='{prefix}'>
<h3>{escape(row['renderer'])} on {escape(row['scene'])}</h3>{stale}
<p class='note'>{row['seeds']} file(s) at {row['width']}×{row['height']} from <code>{escape(row['folder'])}</code>;
reference <code>{escape(ref['key'])}</code> (noise floor {escape(floors)}); {row['compared_pixels']:,} pixels compared
(glass excluded by {masks}).
{'Only combined was given (root R, G, B): ' + ', '.join(missing) + ' not compared.' if missing else ''}
Relative MSE debiased: less the reference's floor and, with ≥ 2 files, the renderer's own variance over them.</p>
{'<ul>' + warnings + '</ul>' if warnings else ''}
{_component_table(row)}
{''.join(renders)}
<p class='note'>One exposure per component: {', '.join(f'{c} ×{v:.4g}' for c, v in row['exposure'].items())}
(the reference's bright pixels to 1; linear, then sRGB).</p>
{''.join(maps)}
</div>"""


def scene_comparisons(scene: str, rows: list, media: list) -> str:
    """The report's "Other renderers" part of one scene's section: each comparison of
    ``scene`` (``rows``: the summary's comparisons, ``media``: their images, in order)."""
    parts = [comparison_section(row["anchor"], row, images) for row, images in zip(rows, media)
             if row["scene"] == scene]
    return f"<h3>Other renderers</h3>{''.join(parts)}" if parts else ""


def comparison_page(row: dict, images: dict) -> str:
    """``compare``'s own ``index.html``: one renderer's section, self-contained."""
    return f"""<!doctype html>
<html lang='en'><head><meta charset='utf-8'><meta name='viewport' content='width=device-width, initial-scale=1'>
<title>volcaustics compare: {escape(row['renderer'])} on {escape(row['scene'])}</title><style>{CSS}</style></head><body>
<h1>{escape(row['renderer'])} against ground truth: {escape(row['scene'])}</h1>
<p class='note'>Every number here is in <code>summary.json</code> beside this page; per metric and component in
<code>images.parquet</code>. Errors over the pixels where no renderer sees glass.</p>
{comparison_section('c0', row, images)}
<script>{SCRIPT}</script></body></html>
"""


def renderers_table(pages: Sequence[ScenePage], rows: Sequence[Mapping]) -> str:
    """The overview's "Renderers" table: per scene the approximation, then each other
    renderer compared on it (``rows``: the report's comparisons; empty without ``report --compare``)."""
    if not rows:
        return ""
    head = ("<tr><th class='l'>scene</th><th class='l'>renderer</th><th>size, seeds</th>"
            "<th>caustic relative MSE, debiased</th><th>caustic energy ratio</th>"
            "<th>combined relative MSE, debiased</th><th>combined energy ratio</th><th>combined HDR-FLIP</th></tr>")
    body = []
    for index, page in enumerate(pages):
        entries = [("approximation (this report)", page.params["width"], page.params["height"],
                    len(page.seed_values), page.components, f"#scene-{index}")]
        entries += [(r["renderer"], r["width"], r["height"], r["seeds"],
                     {c: ComponentErrors.from_json(v) for c, v in r["images"].items()}, f"#{r['anchor']}")
                    for r in rows if r["scene"] == page.scene]
        if len(entries) == 1:
            continue
        for k, (name, w, h, seeds, images, anchor) in enumerate(entries):
            def shown(c: str, metric: str, images: Mapping = images) -> Estimate:
                return images[c].estimate(metric) if c in images else MISSING  # a layer the renderer lacks

            cells = "".join(f"<td>{debiased_pct(shown(c, 'relative_mse').debiased)}</td>"
                            f"<td>{_num(shown(c, 'energy_ratio').value, '{:.3f}')}</td>"
                            for c in ("caustic", "combined"))
            flip = shown("combined", "hdr_flip").value
            scene_cell = f"<td class='l' rowspan={len(entries)}>{escape(page.scene)}</td>" if k == 0 else ""
            body.append(f"<tr class='renderer-row' data-scene='{escape(page.scene)}' "
                        f"data-renderer='{escape(name)}'>{scene_cell}<td class='l'><a href='{anchor}'>"
                        f"{escape(name)}</a></td><td>{w}×{h}, {seeds}</td>{cells}<td>{_num(flip)}</td></tr>")
    return (f"<h3 id='renderers'>Renderers</h3><p class='note'>Other renderers' images of the same scenes "
            f"(<code>volcaustics compare</code>), measured as the approximation is; – where a renderer gave no such "
            f"layer.</p><table id='renderers-table'>{head}{''.join(body)}</table>")
