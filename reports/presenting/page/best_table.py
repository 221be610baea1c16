"""The report's best-configuration table (``volcaustics sweep --best``): per scene the
paper's configuration, the adopted one and the scene's best at ≤ the paper's frame cost,
by the search's criterion, with every decomposition term's part."""

from __future__ import annotations

from collections.abc import Mapping
from html import escape

from volcaustics.metrics.decomposition import TERMS as BEST_TERMS
from volcaustics.reports.presenting.page.parts import debiased_pct
from volcaustics.reports.presenting.page.parts import num as _num


def percent_pm(value: float | None, se: float | None, fmt: str = "{:.2f}") -> str:
    """A relative MSE in % (two decimals) with its standard error."""
    if value is None:
        return "–"
    return fmt.format(100 * value) + "%" + (f" ± {100 * se:.2f}" if se is not None else "")


def best_table(best: Mapping | None) -> str:
    if not best:
        return ""
    v = best["verdict"]
    head = ("<tr><th class='l'>scene</th><th class='l'>role</th><th class='l'>configuration</th><th>photon_res</th>"
            "<th>frame cost</th><th>vs the paper's</th><th>caustic relMSE</th><th>vs the paper's</th>"
            "<th>one frame's relMSE</th><th>vs the paper's</th>"
            + "".join(f"<th>{escape(t)}</th>" for t in BEST_TERMS) + "</tr>")
    rows = "".join(
        f"<tr><td class='l'>{escape(r['scene'])}</td><td class='l'>{escape(r['role'])}</td>"
        f"<td class='l'>{escape(r['config'])}</td><td>{r['photon_res']}</td>"
        f"<td>{_num((r.get('frame_cost') or 0) / 1e6 or None, '{:.2f} M')}</td>"
        f"<td>{_num(r['cost_ratio'], '{:.3f}×')}</td>"
        f"<td>{debiased_pct(r['caustic_relmse_debiased'], se=r.get('caustic_relmse_se'))}</td>"
        f"<td>{_num(r['relmse_ratio'], '{:.2f}×')}</td>"
        f"<td>{debiased_pct(r.get('frame_relmse'), se=r.get('frame_relmse_se'))}</td>"
        f"<td>{_num(r.get('frame_ratio'), '{:.2f}×')}</td>"
        + "".join(f"<td>{percent_pm(r.get(f'relmse_{t}'), None, '{:+.2f}')}</td>" for t in BEST_TERMS) + "</tr>"
        for r in best["rows"])
    if v.get("adopted") is None:
        goal = "<p class='warn'>No configuration was measured on every scene.</p>"
    else:
        crit = "one frame's caustic relMSE" if v.get("criterion") == "frame" else "caustic relMSE (the mean's bias)"
        dearer = "" if v["within_cost"] else ", and it costs more somewhere"
        goal = (f"<p class='note' id='best-verdict'>Adopted for every scene by {crit}: "
                f"<code>{escape(v['adopted'])}</code>. Its worst ratio to the paper's configuration is "
                f"{v['worst_ratio']:.2f}× (goal ≤ {v['goal']:g}×{dearer}): the goal is "
                f"<b>{'met' if v['met'] else 'not met'}</b>. One frame (bias and the frame's own noise, what a "
                f"viewer sees): worst {_num(v.get('worst_frame_ratio'), '{:.2f}×')}; the mean's bias: worst "
                f"{_num(v.get('worst_bias_ratio'), '{:.2f}×')}.</p>")
    return f"""<h3 id='best'>The best configuration at the paper's cost</h3>
<p class='note'>{best['points']} points of <code>volcaustics sweep --best</code> (reports/studies/best/best_search.py):
every configuration at the photon_res that makes its frame cost (map and emission reads + splats, hardware-independent)
at most the paper configuration's on that scene; a coarse grid, then one-axis moves from the configuration with the
least worst ratio over the scenes. Per scene: the paper's configuration, the adopted one and the scene's own best; the
decomposition terms are their parts of the caustic's relative MSE, noise removed (figure
<code>best_configuration</code>).</p>
{goal}
<table id='best-table'>{head}{rows}</table>"""
