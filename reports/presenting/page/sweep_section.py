"""The report's sweep section (``report --sweep DIR``): the settings that suffice per
scene, a variants sweep's best variant per scene and the best-configuration search's
table, with the sweep's figures."""

from __future__ import annotations

from collections.abc import Mapping
from html import escape
from typing import TYPE_CHECKING

from volcaustics.reports.presenting.page.best_table import best_table as _best_table
from volcaustics.reports.presenting.page.parts import num as _num
from volcaustics.reports.presenting.page.parts import pct as _pct
from volcaustics.reports.studies.sweep.variants import variant_name

if TYPE_CHECKING:
    from volcaustics.reports.presenting.page.report_document import SweepSummary


def sweep_section(sweep: SweepSummary | None, figures: dict) -> str:
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
                   for r in sweep.suffice)
    factor = sweep.suffice_factor
    return f"""
<section id='sweep'><h2>Sweep</h2>
<p class='note'>Store <code>{escape(sweep.folder)}</code>: {sweep.points} points; varied
{escape(', '.join(sweep.varied))}.</p>
{"".join(f"<p class='warn sweep-note'>{escape(n)}.</p>" for n in sweep.notes)}
<h3>Settings that suffice</h3>
<p class='note'>Per scene: the fewest layers / iterations / peak_samples whose error is within
{_num(factor, '{:g}')}× the best over that parameter (the other varied parameters at their largest).</p>
<table id='suffice'>{head}{rows}</table>
{variants_table(sweep.variants)}
{_best_table(sweep.best)}
{figs}
</section>"""


def _pm(value, se) -> str:
    """A share in % with its standard error."""
    if value is None:
        return "–"
    return f"{100 * value:+.1f}%" + (f" ± {100 * se:.1f}" if se is not None else "")


def variants_table(variants: Mapping | None) -> str:
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
