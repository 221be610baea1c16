"""The report page: one self-contained HTML file (images as data URIs, inline CSS and
script, nothing fetched), drawn from the report's summary (``page.summary``).

Verdicts are words and symbols on a coloured ground, never colour alone. Renders
are drawn with ``image-rendering: pixelated``; hovering an approximation shows the
reference in its place, clicking keeps it (Blender's render report does this).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from html import escape

from volcaustics.metrics.intersection import OUTCOME_CLASSES
from volcaustics.reports.presenting.page.animations import over_time_section
from volcaustics.reports.presenting.page.best_table import best_table as _best_table
from volcaustics.reports.presenting.page.data_uris import SCALES, colour_bar_css, data_uri
from volcaustics.reports.presenting.page.decomposition_section import OVERVIEW_HEAD as DECOMPOSITION_HEAD
from volcaustics.reports.presenting.page.decomposition_section import decomposition_table
from volcaustics.reports.presenting.page.decomposition_section import overview_cell as decomposition_cell
from volcaustics.reports.presenting.page.external import renderers_table, scene_comparisons
from volcaustics.reports.presenting.page.first_screen import (
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
from volcaustics.reports.studies.sweep.variants import variant_name
from volcaustics.scenes.formats import COLOUR_LAYERS


def _check_text(check: dict) -> str:
    if check["name"].startswith("regression"):
        value = None if check["value"] is None else 100 * check["value"]
        return f"{check['name']} {_num(value, '{:+.2f}%')} ({check['limit']})"
    return f"{check['name']} {_num(check['value'], '{:.4g}')} ({check['limit']})"


def _gate_cell(gate: dict) -> str:
    parts = [_verdict(c["passed"], _check_text(c)) for c in gate["checks"]]
    if gate["note"]:
        parts.append(f"<span class='note'>{escape(gate['note'])}</span>")
    return "<br>".join(parts) or _verdict(None, "no checks")


def _gate_line(gate: dict) -> str:
    """The scene's gate in one line: its failures, else one pass for all checks."""
    failed = [c for c in gate["checks"] if not c["passed"]]
    if failed:
        return "Gate: " + " ".join(_verdict(False, _check_text(c)) for c in failed)
    if gate["checks"]:
        return "Gate: " + _verdict(True, f"all {len(gate['checks'])} checks") + (
            f" <span class='note'>{escape(gate['note'])}</span>" if gate["note"] else "")
    return "Gate: " + _verdict(None, gate["note"] or "no checks")


def _params_cell(params: dict) -> str:
    p = dict(params)
    size = f"{p.pop('width')}×{p.pop('height')}"
    return "<span class='note'>" + "<br>".join([size] + [f"{escape(k)} {escape(str(v))}" for k, v in p.items()]) \
        + "</span>"


def _overview(summary: dict, shared: dict) -> str:
    head = ("<tr><th class='l'>scene</th><th class='l'>component</th><th>relative MSE, debiased [95% interval]</th>"
            "<th>one frame's relative MSE ± SE</th><th>reference noise floor</th><th>energy ratio [95%]</th>"
            "<th>HDR-FLIP per frame</th>" + OVERVIEW_HEAD +
            DECOMPOSITION_HEAD +
            "<th class='l'>gate (failures first)</th><th>frame time<br>map reads</th><th class='l'>parameters</th></tr>")
    body = []
    for index, page in enumerate(summary["scenes"]):
        for k, component in enumerate(COLOUR_LAYERS):
            c = page["components"][component]
            relmse, energy, flip = c["relative_mse"], c["energy_ratio"], c["hdr_flip"]
            frame_err = c.get("frame_relative_mse") or {}
            cells = [f"<td class='l'>{component}</td>",
                     f"<td>{debiased_pct(relmse.get('debiased'), low=relmse.get('ci_low'), high=relmse.get('ci_high'))}"
                     "</td>",
                     f"<td>{debiased_pct(frame_err.get('debiased'), se=frame_err.get('standard_error'))}</td>",
                     f"<td>{_pct(c['reference_noise_floor'], 3)}</td>",
                     f"<td>{_num(energy.get('value'), '{:.3f}')}"
                     + (f" [{_num(energy.get('ci_low'), '{:.3f}')}, {_num(energy.get('ci_high'), '{:.3f}')}]"
                        if energy.get("ci_low") is not None else "") + "</td>",
                     f"<td>{_num(flip.get('value'))}</td>", overview_cell(page, component),
                     decomposition_cell(page, component)]
            if k == 0:
                n = len(COLOUR_LAYERS)
                frame = page["timing"]["frame_s"]
                reads = (page["timing"].get("map_reads") or {}).get("per_frame")
                cells.insert(0, f"<td class='l' rowspan={n}><a href='#scene-{index}'>{escape(page['scene'])}</a></td>")
                cells += [f"<td class='l gate' rowspan={n}>{_gate_cell(page['gate'])}</td>",
                          f"<td rowspan={n}>{_num(None if frame is None else 1000 * frame, '{:.0f} ms')}<br>"
                          f"{_num(None if reads is None else reads / 1e6, '{:.2f} M')}</td>",
                          f"<td class='l' rowspan={n}>{_params_cell(own_params(page, shared))}</td>"]
            body.append(f"<tr class='overview-row' data-scene='{escape(page['scene'])}'>{''.join(cells)}</tr>")
    return f"<table id='overview'>{head}{''.join(body)}</table>"


def _banner(summary: dict) -> str:
    gate = summary["gate"]
    failed = [c for p in summary["scenes"] for c in p["gate"]["checks"] if not c["passed"]]
    items = "".join(f"<li>{escape(c['scene'])}: {escape(_check_text(c))}</li>" for c in failed)
    unchecked = [p for p in summary["scenes"] if p["scene"] in gate["unchecked_scenes"]]
    items += "".join(f"<li>{escape(p['scene'])}: {escape(p['gate']['note'])}</li>" for p in unchecked)
    if gate["passed"] is True:
        status, text = "pass", f"✓ Gate passed: all {gate['checks']} checks within their budgets"
    elif gate["passed"] is False:
        status, text = "fail", f"✗ Gate FAILED: {gate['failed']} of {gate['checks']} checks"
    elif gate["unchecked_scenes"]:
        status, text = "fail", (f"✗ Gate not fully checked: {len(gate['unchecked_scenes'])} scene(s) with budgets "
                                f"could not be checked (`volcaustics gate` exits 2 on them)")
    else:
        status, text = "none", "– Gate: nothing checked (no budgets for these scenes)"
    if gate["scenes_without_budgets"]:
        text += f"; no budgets: {', '.join(gate['scenes_without_budgets'])}"
    return f"<div class='banner {status}'>{escape(text)}.{'<ul>' + items + '</ul>' if items else ''}</div>"


def _renders(index: int, page: dict, images: dict, width: int) -> str:
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
    exposure = page["exposure"]
    return ("".join(out) + f"<p class='note'>One exposure per component for every image of it: caustic ×"
            f"{_num(exposure['caustic'], '{:.4g}')}, combined ×{_num(exposure['combined'], '{:.4g}')} (linear, "
            f"then sRGB).</p>")


def _maps(page: dict, images: dict, summary: dict, bars: dict, width: int) -> str:
    out = []
    for metric, scale in summary["scales"].items():
        items = []
        for component in ("caustic", "combined"):
            mean = page["components"][component].get(metric, {}).get("value")
            items.append(_figure(images[f"map.{metric}.{component}"],
                                 f"{escape(scale['label'])}, {component}: the first seed's frame (mean over the "
                                 f"frames {_num(mean)})", width=width))
        items.append(f"<div>{_colour_bar({**scale, 'ticks': bars[metric]['ticks']}, bars[metric]['css'])}</div>")
        out.append(f"<div class='row'>{''.join(items)}</div>")
    return "".join(out)


def _hit_table(hits: dict) -> str:
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


def _timing_table(t: dict) -> str:
    paper = t["paper_shares"]
    rows = "".join(f"<tr><td class='l'>{p['pass']}</td><td>{_num(_thousand(p['seconds']), '{:.1f} ms')}</td>"
                   f"<td>{_pct(p['share'], 0)}</td><td>{_pct(paper.get(p['pass']), 0)}</td></tr>"
                   for p in t["passes"])
    return (f"<table><tr><th class='l'>pass</th><th>time</th><th>share</th><th>paper's share</th></tr>{rows}"
            f"<tr><td class='l'>frame</td><td>{_num(_thousand(t['frame_s']), '{:.1f} ms')}</td><td></td><td></td>"
            f"</tr></table><p class='note'>One frame without records, the median of {_num(t['timed_frames'], '{}')}; "
            f"measured by {escape(t['method'])} on {escape(str(t['gl_renderer']))}.</p>")


def _thousand(value):
    return None if value is None else 1000.0 * value


def _scene_section(index: int, page: dict, images: dict, summary: dict, bars: dict, comparison_media=()) -> str:
    name = page["scene"]
    width = page["params"]["width"] * max(1, 256 // page["params"]["width"])  # small renders magnified, pixelated
    ref = page["reference"]
    floors = ", ".join(f"{k} {_pct(v, 3)}" for k, v in (ref.get("noise_floor") or {}).items())
    warnings = "".join(f"<li class='warn'>{escape(w)}</li>" for w in page["warnings"])
    return f"""
<section id='scene-{index}'>
<h2>{escape(name)}</h2>
<p>{escape(page['description'])}.</p><p>{_gate_line(page['gate'])}</p>
<p class='note'>Reference <code>{escape(ref['key'])}</code>: {_num(ref['photons'], '{:,}')} photons,
{_num(ref['batches'], '{}')} caustic and {_num(ref['camera_batches'], '{}')} camera batches, noise floor
{escape(floors)} over its own non-glass pixels (stopped by {escape(str(ref['stopped_by']))});
seeds {escape(', '.join(str(s) for s in page['seed_values']))}; {page['compared_pixels']:,} pixels compared.
Result <code>{escape(page['point'])}</code> {'measured in this run' if page['measured_in_this_run'] else 'from the result store'}.</p>
{'<ul>' + warnings + '</ul>' if warnings else ''}
<h3>Images</h3>
{_renders(index, page, images, width)}
<h3>Error maps (fixed scales)</h3>
{_maps(page, images, summary, bars, width)}
{scene_comparisons(page['scene'], summary.get('comparisons') or [], list(comparison_media))}
<h3>Intersection: hit classes by step and layer</h3>
<div class='row'><div>{_hit_table(page['hit_classes'])}</div>
<img class='chart' src='{images['chart.hit_classes']}' alt='hit classes of {escape(name)} by step and layer'></div>
<h3>Power by fate per step (both tracers)</h3>
<img class='chart' src='{images['chart.power_budget']}' alt='power budget of {escape(name)}'>
<h3>The caustic's error, decomposed</h3>
<div class='row'><img class='chart' src='{images['chart.decomposition']}' alt='decomposition of {escape(name)}'>
<div>{decomposition_table(page['decomposition'])}</div></div>
{model_section(page)}
<h3>Time per pass</h3>
<div class='row'><img class='chart' src='{images['chart.pass_times']}' alt='pass times of {escape(name)}'>
<div>{_timing_table(page['timing'])}</div></div>
</section>"""


def sweep_section(sweep: dict, figures: dict) -> str:
    if sweep is None:
        return ""
    figs = "".join(f"<figure><img class='chart' src='{uri}' alt='{escape(name)}'><figcaption>{escape(name)}"
                   f"</figcaption></figure>" for name, uri in figures.items())
    head = ("<tr><th class='l'>scene</th><th class='l'>variant</th><th class='l'>parameter</th>"
            "<th class='l'>criterion</th><th>suffices</th><th>its error</th><th>best</th><th>largest tried</th>"
            "<th>frame time</th><th>map reads</th></tr>")
    rows = "".join(f"<tr><td class='l'>{escape(r['scene'])}</td><td class='l'>{escape(variant_name(r))}</td>"
                   f"<td class='l'>{escape(r['parameter'])}</td><td class='l'>{escape(r['criterion'])}</td>"
                   f"<td>{r['suffices']:g}</td><td>{_pct(r['error'])}</td><td>{_pct(r['best'])}</td>"
                   f"<td>{r['largest']:g}</td><td>{_num(r['frame_time_s'], '{:.3f} s')}</td>"
                   f"<td>{_num((r.get('map_reads_per_frame') or 0) / 1e6 or None, '{:.2f} M')}</td></tr>"
                   for r in sweep["suffice"])
    factor = sweep["suffice_factor"]
    return f"""
<section id='sweep'><h2>Sweep</h2>
<p class='note'>Store <code>{escape(sweep['folder'])}</code>: {sweep['points']} points; varied
{escape(', '.join(sweep['varied']))}.</p>
{"".join(f"<p class='warn sweep-note'>{escape(n)}.</p>" for n in sweep.get('notes') or [])}
<h3>Settings that suffice</h3>
<p class='note'>Per scene: the fewest layers / iterations / peak_samples whose error is within
{_num(factor, '{:g}')}× the best over that parameter (the other varied parameters at their largest).</p>
<table id='suffice'>{head}{rows}</table>
{variants_table(sweep.get('variants'))}
{_best_table(sweep.get('best'))}
{figs}
</section>"""


def _pm(value, se) -> str:
    """A share in % with its standard error."""
    if value is None:
        return "–"
    return f"{100 * value:+.1f}%" + (f" ± {100 * se:.1f}" if se is not None else "")


def variants_table(variants: dict | None) -> str:
    if not variants:
        return ""
    head = ("<tr><th class='l'>scene</th><th class='l'></th><th class='l'>variant</th><th>layers</th>"
            "<th>peak_samples</th><th>iterations</th><th>map reads / segment</th><th>frame time</th>"
            "<th>intersection term (energy)</th><th>its relMSE part</th><th>step 2 wrong surface</th>"
            "<th>step 2 missed</th><th>vs the paper's: |energy|, relMSE part</th></tr>")
    rows = "".join(
        f"<tr><td class='l'>{escape(r['scene'])}</td><td class='l'>{escape(r['role'])}</td>"
        f"<td class='l'>{escape(variant_name(r))}</td><td>{r['layers']}</td><td>{r['peak_samples']}</td>"
        f"<td>{r['iterations']}</td><td>{_num(r['map_reads_per_segment'], '{:.1f}')}</td>"
        f"<td>{_num(r['frame_time_s'], '{:.2f} s')}</td>"
        f"<td>{_pm(r['share_intersection'], r.get('share_intersection_se'))}</td>"
        f"<td>{_pm(r.get('intersection_relmse_part'), r.get('intersection_relmse_part_se'))}</td>"
        f"<td>{_num(r.get('step2_wrong_surface'), '{:.1f}%')}</td><td>{_num(r.get('step2_missed'), '{:.1f}%')}</td>"
        f"<td>{_num(r.get('share_ratio'), '{:.2f}×')}, {_num(r.get('relmse_ratio'), '{:.2f}×')}</td></tr>"
        for r in variants["best"])
    return f"""<h3 id='variants'>Variants</h3>
<p class='note'>Per scene: the paper's method and the variant whose intersection term (E_k − A) is smallest in both
its parts (the larger of its ratios to the paper's: |energy share| and relative-MSE part) at no more map reads per
segment than the paper's search (hardware-independent cost; llvmpipe frame time beside it).
Figures <code>variants_&lt;scene&gt;</code> below: every variant, the Pareto front, the paper's point circled.</p>
<table id='variants-best'>{head}{rows}</table>"""


def render_page(summary: dict, images: dict, sweep_figures: dict, animation_media: Iterable[dict] = (),
                comparison_media: Sequence[dict] = ()) -> str:
    """The page; ``images``: scene → name → data URI (``page.write.scene_images``);
    ``animation_media``: per ``summary["animations"]`` row its data URIs;
    ``comparison_media``: per ``summary["comparisons"]`` row its data URIs
    (``page.external.comparison_images``)."""
    bars = {name: {"css": colour_bar_css(scale), "ticks": scale.ticks()} for name, scale in SCALES.items()}
    params = summary["params"]
    nav = "".join(f"<a href='#scene-{i}'>{escape(p['scene'])}</a>" for i, p in enumerate(summary["scenes"]))
    if summary["sweep"] is not None:
        nav += "<a href='#sweep'>sweep</a>"
    animations = summary.get("animations") or []
    if animations:
        nav += "<a href='#over-time'>over time</a>"
    if summary.get("comparisons"):
        nav += "<a href='#renderers'>renderers</a>"
    if summary.get("frames"):
        nav += "<a href='#one-frame'>one frame</a>"
    sections = "".join(_scene_section(i, p, images[p["scene"]], summary, bars, comparison_media)
                       for i, p in enumerate(summary["scenes"]))
    shared = shared_params(summary)
    chart = _figure(data_uri(error_by_cause_chart(summary)), "Every scene's caustic error split into its causes "
                    "(the decomposition's debiased parts, stacked), the mean image's relative MSE (◆) and one "
                    "frame's (grey): what a viewer sees", cls="chart") if summary["scenes"] else ""
    first = f"<div id='error-by-cause'>{chart}</div>"
    return f"""<!doctype html>
<html lang='en'><head><meta charset='utf-8'><meta name='viewport' content='width=device-width, initial-scale=1'>
<title>volcaustics accuracy report</title><style>{CSS}</style></head><body>
<h1>volcaustics — accuracy of image-based photon tracing against ground truth</h1>
<p class='note'>{escape(summary['created'])}; measured with GL {escape(', '.join(summary['gl_renderers']))};
code {escape(summary['code_version'])}; every number here is in <code>summary.json</code> beside this page.</p>
{first}
{_banner(summary)}
{shared_params_line(shared)}
<nav>{nav}</nav>
<h2>Overview</h2>
<p class='note'>Errors over the pixels where neither renderer sees glass. Relative MSE Σ(A − R)²/ΣR² of the seeds'
mean, debiased (less the reference's noise floor and the approximation's own noise over
{summary['seeds']} seeds; jackknife interval, Student t). Energy ratio ΣA/ΣR (1 = same energy). HDR-FLIP: mean over
frames (0 = identical, 1 = worst). Budgets: <code>{escape(summary['budgets'])}</code>
{'; baseline <code>' + escape(summary['baseline']) + '</code>' if summary['baseline'] else '; no baseline (no regression test)'}.</p>
{_overview(summary, shared)}
{frames_section(summary.get("frames"))}
{renderers_table(summary)}
<details><summary>parameters used</summary><p>approximation: <code>{escape(json.dumps(params))}</code><br>
reference: <code>{escape(json.dumps(summary['reference_settings']))}</code><br>
measurement: <code>{escape(json.dumps(summary.get('measurement', {})))}</code></p></details>
{sections}
{sweep_section(summary['sweep'], sweep_figures)}
{over_time_section(animations, list(animation_media))}
<script>{SCRIPT}</script>
</body></html>
"""
