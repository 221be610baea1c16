"""The report page: one self-contained HTML file (images as data URIs, inline CSS and
script, nothing fetched), drawn from the report's document (``page.report_document``).

Verdicts are words and symbols on a coloured ground, never colour alone. Renders
are drawn with ``image-rendering: pixelated``; hovering an approximation shows the
reference in its place, clicking keeps it (Blender's render report does this).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from html import escape
from typing import TYPE_CHECKING, cast

from volcaustics.metrics.intersection import OUTCOME_CLASSES
from volcaustics.reports.presenting.page.animations import over_time_section
from volcaustics.reports.presenting.page.data_uris import SCALES, colour_bar_css, data_uri
from volcaustics.reports.presenting.page.decomposition_section import OVERVIEW_HEAD as DECOMPOSITION_HEAD
from volcaustics.reports.presenting.page.decomposition_section import decomposition_table
from volcaustics.reports.presenting.page.decomposition_section import overview_cell as decomposition_cell
from volcaustics.reports.presenting.page.external import renderers_table, scene_comparisons
from volcaustics.reports.presenting.page.first_screen import (
    cause_bar,
    error_by_cause_chart,
    own_params,
    shared_params,
    shared_params_line,
)
from volcaustics.reports.presenting.page.frame_check_section import frames_section
from volcaustics.reports.presenting.page.model_section import OVERVIEW_HEAD, model_section, overview_cell
from volcaustics.reports.presenting.page.parts import CSS, SCRIPT, debiased_pct
from volcaustics.reports.presenting.page.parts import colour_bar as _colour_bar
from volcaustics.reports.presenting.page.parts import figure as _figure
from volcaustics.reports.presenting.page.parts import num as _num
from volcaustics.reports.presenting.page.parts import pct as _pct
from volcaustics.reports.presenting.page.parts import verdict as _verdict
from volcaustics.reports.presenting.page.sweep_section import sweep_section
from volcaustics.reports.studies.registry import reported, resolve
from volcaustics.scenes.formats import COLOUR_LAYERS

if TYPE_CHECKING:
    from volcaustics.experiment.result import ReferenceUsed
    from volcaustics.reports.presenting.page.report_document import (
        PassTiming,
        ReportDocument,
        SceneGate,
        ScenePage,
    )
    from volcaustics.reports.studies.gate.budgets import Check
    from volcaustics.reports.studies.study import ReportInput


def _check_text(check: Check) -> str:
    if check.name.startswith("regression"):
        value = None if check.value is None else 100 * check.value
        return f"{check.name} {_num(value, '{:+.2f}%')} ({check.limit})"
    return f"{check.name} {_num(check.value, '{:.4g}')} ({check.limit})"


def _gate_cell(gate: SceneGate) -> str:
    parts = [_verdict(c.passed, _check_text(c)) for c in gate.checks]
    if gate.note:
        parts.append(f"<span class='note'>{escape(gate.note)}</span>")
    return "<br>".join(parts) or _verdict(None, "no checks")


def _gate_line(gate: SceneGate) -> str:
    """The scene's gate in one line: its failures, else one pass for all checks."""
    if gate.failed:
        return "Gate: " + " ".join(_verdict(False, _check_text(c)) for c in gate.failed)
    if gate.checks:
        return "Gate: " + _verdict(True, f"all {len(gate.checks)} checks") + (
            f" <span class='note'>{escape(gate.note)}</span>" if gate.note else "")
    return "Gate: " + _verdict(None, gate.note or "no checks")


def _params_cell(params: dict) -> str:
    p = dict(params)
    size = f"{p.pop('width')}×{p.pop('height')}"
    return "<span class='note'>" + "<br>".join([size] + [f"{escape(k)} {escape(str(v))}" for k, v in p.items()]) \
        + "</span>"


def _overview(doc: ReportDocument, shared: dict) -> str:
    head = ("<tr><th class='l'>scene</th><th class='l'>component</th><th>relative MSE, debiased [95% interval]</th>"
            "<th>one frame's relative MSE ± SE</th><th>reference noise floor</th><th>energy ratio [95%]</th>"
            "<th>HDR-FLIP per frame</th>" + OVERVIEW_HEAD +
            DECOMPOSITION_HEAD +
            "<th class='l'>gate (failures first)</th><th>frame time<br>map reads</th><th class='l'>parameters</th></tr>")
    body = []
    for index, page in enumerate(doc.scenes):
        for k, component in enumerate(COLOUR_LAYERS):
            c = page.components[component]
            relmse, energy, flip = c.estimate("relative_mse"), c.estimate("energy_ratio"), c.estimate("hdr_flip")
            frame_err = c.estimate("frame_relative_mse")
            cells = [f"<td class='l'>{component}</td>",
                     f"<td>{debiased_pct(relmse.debiased, low=relmse.ci_low, high=relmse.ci_high)}</td>",
                     f"<td>{debiased_pct(frame_err.debiased, se=frame_err.standard_error)}</td>",
                     f"<td>{_pct(c.reference_noise_floor, 3)}</td>",
                     f"<td>{_num(energy.value, '{:.3f}')}"
                     + (f" [{_num(energy.ci_low, '{:.3f}')}, {_num(energy.ci_high, '{:.3f}')}]"
                        if not math.isnan(energy.ci_low) else "") + "</td>",
                     f"<td>{_num(flip.value)}</td>", overview_cell(page, component),
                     decomposition_cell(page, component)]
            if k == 0:
                n = len(COLOUR_LAYERS)
                frame = page.timing.frame_s
                reads = None if page.timing.map_reads is None else page.timing.map_reads.per_frame
                cells.insert(0, f"<td class='l' rowspan={n}><a href='#scene-{index}'>{escape(page.scene)}</a></td>")
                cells += [f"<td class='l gate' rowspan={n}>{_gate_cell(page.gate)}</td>",
                          f"<td rowspan={n}>{_num(1000 * frame, '{:.0f} ms')}<br>"
                          f"{_num(None if reads is None else reads / 1e6, '{:.2f} M')}</td>",
                          f"<td class='l' rowspan={n}>{_params_cell(own_params(page, shared))}</td>"]
            body.append(f"<tr class='overview-row' data-scene='{escape(page.scene)}'>{''.join(cells)}</tr>")
    return f"<table id='overview'>{head}{''.join(body)}</table>"


def _banner(doc: ReportDocument) -> str:
    gate = doc.gate
    failed = [c for p in doc.scenes for c in p.gate.failed]
    items = "".join(f"<li>{escape(c.scene)}: {escape(_check_text(c))}</li>" for c in failed)
    unchecked = [p for p in doc.scenes if p.scene in gate.unchecked_scenes]
    items += "".join(f"<li>{escape(p.scene)}: {escape(p.gate.note or '')}</li>" for p in unchecked)
    if gate.passed is True:
        status, text = "pass", f"✓ Gate passed: all {gate.checks} checks within their budgets"
    elif gate.passed is False:
        status, text = "fail", f"✗ Gate FAILED: {gate.failed} of {gate.checks} checks"
    elif gate.unchecked_scenes:
        status, text = "fail", (f"✗ Gate not fully checked: {len(gate.unchecked_scenes)} scene(s) with budgets "
                                f"could not be checked (`volcaustics gate` exits 2 on them)")
    else:
        status, text = "none", "– Gate: nothing checked (no budgets for these scenes)"
    if gate.scenes_without_budgets:
        text += f"; no budgets: {', '.join(gate.scenes_without_budgets)}"
    return f"<div class='banner {status}'>{escape(text)}.{'<ul>' + items + '</ul>' if items else ''}</div>"


def _renders(index: int, page: ScenePage, images: dict, width: int) -> str:
    out = []
    for component in ("caustic", "combined"):
        a, r = f"s{index}-approx-{component}", f"s{index}-reference-{component}"
        label = f"{a}-label"
        items = [_figure(images[f"approx.{component}"], f"approximation, {component} (seed mean) — "
                         f"<span id='{label}'>showing: approximation (hover or click: reference)</span>",
                         ident=a, cls="render swap", width=width, extra=f" data-other='{r}' data-label='{label}'")]
        if component == "caustic":
            items.append(_figure(images["exact_steps"], "exact photons E_k: the same photons and random numbers, "
                                                        "exact intersections", width=width))
        items.append(_figure(images[f"reference.{component}"], f"reference (Mitsuba 3), {component}",
                             ident=r, width=width))
        out.append(f"<div class='row'>{''.join(items)}</div>")
    exposure = page.exposure
    return ("".join(out) + f"<p class='note'>One exposure per component for every image of it: caustic ×"
            f"{_num(exposure['caustic'], '{:.4g}')}, combined ×{_num(exposure['combined'], '{:.4g}')} (linear, "
            f"then sRGB).</p>")


def _maps(page: ScenePage, images: dict, doc: ReportDocument, bars: dict, width: int) -> str:
    out = []
    for metric, scale in doc.scales.items():
        items = []
        for component in ("caustic", "combined"):
            mean = page.components[component].estimate(metric).value
            items.append(_figure(images[f"map.{metric}.{component}"],
                                 f"{escape(scale['label'])}, {component}: the first seed's frame (mean over the "
                                 f"frames {_num(mean)})", width=width))
        items.append(f"<div>{_colour_bar({**scale, 'ticks': bars[metric]['ticks']}, bars[metric]['css'])}</div>")
        out.append(f"<div class='row'>{''.join(items)}</div>")
    return "".join(out)


def _hit_table(hits: Mapping) -> str:
    share = "{:.1f}%"
    head = ("<tr><th>step</th><th>segments</th>" + "".join(f"<th>{c.replace('_', ' ')}</th>" for c in OUTCOME_CLASSES)
            + "<th>of which self re-hits</th><th>|Δt| median</th><th>|Δt| p90</th><th>|Δt| p99</th></tr>")
    rows = []
    for r in hits["by_step"]:
        dt = r["abs_dt_mm"]
        rows.append(f"<tr><td>{r['step']}</td><td>{r['segments']:,}</td>"
                    + "".join(f"<td>{_num(r[c], share)}</td>" for c in OUTCOME_CLASSES)
                    + f"<td>{_num(r['self_rehit'], share)}</td>"
                    + "".join(f"<td>{_num(dt[q], '{:.2f} mm')}</td>" for q in ("median", "p90", "p99")) + "</tr>")
    layer_head = ("<tr><th>step</th><th>layer</th><th>segments</th>"
                  + "".join(f"<th>{c.replace('_', ' ')}</th>" for c in OUTCOME_CLASSES) + "<th>self re-hits</th></tr>")
    layer_rows = "".join(f"<tr><td>{r['step']}</td><td>{r['layer']}</td><td>{r['segments']:,}</td>"
                         + "".join(f"<td>{_num(r[c], share)}</td>" for c in OUTCOME_CLASSES)
                         + f"<td>{_num(r['self_rehit'], share)}</td></tr>" for r in hits["rows"])
    return (f"<table class='hits'>{head}{''.join(rows)}</table>"
            f"<details><summary>by step and layer (% of the step's segments)</summary>"
            f"<table>{layer_head}{layer_rows}</table></details>")


def _timing_table(t: PassTiming) -> str:
    rows = "".join(f"<tr><td class='l'>{p.name}</td><td>{_num(_thousand(p.seconds), '{:.1f} ms')}</td>"
                   f"<td>{_pct(p.share, 0)}</td><td>{_pct(t.paper_shares.get(p.name), 0)}</td></tr>"
                   for p in t.passes)
    return (f"<table><tr><th class='l'>pass</th><th>time</th><th>share</th><th>paper's share</th></tr>{rows}"
            f"<tr><td class='l'>frame</td><td>{_num(_thousand(t.frame_s), '{:.1f} ms')}</td><td></td><td></td>"
            f"</tr></table><p class='note'>One frame without records, the median of {_num(t.timed_frames, '{}')}; "
            f"measured by {escape(t.method)} on {escape(str(t.gl_renderer))}.</p>")


def _thousand(value):
    return None if value is None else 1000.0 * value


def _scene_section(index: int, page: ScenePage, images: dict, doc: ReportDocument, bars: dict,
                   comparison_media=()) -> str:
    name = page.scene
    width = page.params["width"] * max(1, 256 // page.params["width"])  # small renders magnified, pixelated
    ref = cast("ReferenceUsed", page.reference)  # the report's scenes are measured against a reference
    floors = ", ".join(f"{k} {_pct(v, 3)}" for k, v in ref.noise_floor.items())
    warnings = "".join(f"<li class='warn'>{escape(w)}</li>" for w in page.warnings)
    return f"""
<section id='scene-{index}'>
<h2>{escape(name)}</h2>
<p>{escape(page.description)}.</p><p>{_gate_line(page.gate)}</p>
<p class='note'>Reference <code>{escape(ref.key)}</code>: {_num(ref.photons, '{:,}')} photons,
{_num(ref.batches, '{}')} caustic and {_num(ref.camera_batches, '{}')} camera batches, noise floor
{escape(floors)} over its own non-glass pixels (stopped by {escape(ref.stopped_by)});
seeds {escape(', '.join(str(s) for s in page.seed_values))}; {page.compared_pixels:,} pixels compared.
Result <code>{escape(page.point)}</code> {'measured in this run' if page.measured_in_this_run else 'from the result store'}.</p>
{'<ul>' + warnings + '</ul>' if warnings else ''}
<h3>Images</h3>
{_renders(index, page, images, width)}
<h3>Error maps (fixed scales)</h3>
{_maps(page, images, doc, bars, width)}
{scene_comparisons(page.scene, list(doc.comparisons), list(comparison_media))}
<h3>Intersection: hit classes by step and layer</h3>
<div class='row'><div>{_hit_table(page.hit_classes)}</div>
<img class='chart' src='{images['chart.hit_classes']}' alt='hit classes of {escape(name)} by step and layer'></div>
<h3>Power by fate per step (both tracers)</h3>
<img class='chart' src='{images['chart.power_budget']}' alt='power budget of {escape(name)}'>
<h3>The caustic's error, decomposed</h3>
<div class='row'><img class='chart' src='{images['chart.decomposition']}' alt='decomposition of {escape(name)}'>
<div>{decomposition_table(page.decomposition)}</div></div>
{model_section(page)}
<h3>Time per pass</h3>
<div class='row'><img class='chart' src='{images['chart.pass_times']}' alt='pass times of {escape(name)}'>
<div>{_timing_table(page.timing)}</div></div>
</section>"""


def other_sections(doc: ReportDocument, media: Mapping[str, Sequence[dict]]) -> str:
    """The sections of the studies the page does not place itself (``reports.studies.study.
    ReportInput.section``): each reported study whose field the document keeps in ``extra``."""
    parts = []
    for study in reported():
        report = cast("ReportInput", study.report)
        if report.section and report.field in doc.extra:
            parts.append(resolve(report.section)(doc.extra[report.field], list(media.get(report.field, ()))))
    return "".join(parts)


def render_page(doc: ReportDocument, images: dict, sweep_figures: dict,
                media: Mapping[str, Sequence[dict]] | None = None) -> str:
    """The page; ``images``: scene → name → data URI (``page.write.scene_images``);
    ``media``: per field of the document a study filled, per row its data URIs
    (``animations``: page.animations; ``comparisons``: ``page.external.comparison_images``)."""
    media = media or {}
    animation_media, comparison_media = list(media.get("animations", ())), list(media.get("comparisons", ()))
    bars = {name: {"css": colour_bar_css(scale), "ticks": scale.ticks()} for name, scale in SCALES.items()}
    nav = "".join(f"<a href='#scene-{i}'>{escape(p.scene)}</a>" for i, p in enumerate(doc.scenes))
    if doc.sweep is not None:
        nav += "<a href='#sweep'>sweep</a>"
    animations = list(doc.animations)
    if animations:
        nav += "<a href='#over-time'>over time</a>"
    if doc.comparisons:
        nav += "<a href='#renderers'>renderers</a>"
    if doc.frames:
        nav += "<a href='#one-frame'>one frame</a>"
    sections = "".join(_scene_section(i, p, images[p.scene], doc, bars, comparison_media)
                       for i, p in enumerate(doc.scenes))
    shared = shared_params(doc.scenes)
    chart = _figure(data_uri(error_by_cause_chart([cause_bar(p) for p in doc.scenes])),
                    "Every scene's caustic error split into its causes "
                    "(the decomposition's debiased parts, stacked), the mean image's relative MSE (◆) and one "
                    "frame's (grey): what a viewer sees", cls="chart") if doc.scenes else ""
    first = f"<div id='error-by-cause'>{chart}</div>"
    return f"""<!doctype html>
<html lang='en'><head><meta charset='utf-8'><meta name='viewport' content='width=device-width, initial-scale=1'>
<title>volcaustics accuracy report</title><style>{CSS}</style></head><body>
<h1>volcaustics — accuracy of image-based photon tracing against ground truth</h1>
<p class='note'>{escape(doc.created)}; measured with GL {escape(', '.join(doc.gl_renderers))};
code {escape(doc.code_version)}; every number here is in <code>summary.json</code> beside this page.</p>
{first}
{_banner(doc)}
{shared_params_line(shared)}
<nav>{nav}</nav>
<h2>Overview</h2>
<p class='note'>Errors over the pixels where neither renderer sees glass. Relative MSE Σ(A − R)²/ΣR² of the seeds'
mean, debiased (less the reference's noise floor and the approximation's own noise over
{doc.seeds} seeds; jackknife interval, Student t). Energy ratio ΣA/ΣR (1 = same energy). HDR-FLIP: mean over
frames (0 = identical, 1 = worst). Budgets: <code>{escape(doc.budgets)}</code>
{'; baseline <code>' + escape(doc.baseline) + '</code>' if doc.baseline else '; no baseline (no regression test)'}.</p>
{_overview(doc, shared)}
{frames_section(doc.frames)}
{renderers_table(doc.scenes, list(doc.comparisons))}
<details><summary>parameters used</summary><p>approximation: <code>{escape(json.dumps(dict(doc.params)))}</code><br>
reference: <code>{escape(json.dumps(dict(doc.reference_settings)))}</code><br>
measurement: <code>{escape(json.dumps(dict(doc.measurement)))}</code></p></details>
{sections}
{sweep_section(doc.sweep, sweep_figures)}
{over_time_section(animations, animation_media)}
{other_sections(doc, media)}
<script>{SCRIPT}</script>
</body></html>
"""
