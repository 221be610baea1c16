"""The caustic's error by cause on the report's page: each scene's decomposition table,
and its overview cell (the terms' debiased relMSE parts, emission first, and whether
the residual is within noise; a term that is exactly 0, its two images the same, is left
out of the cell: march and camera_volume in a homogeneous medium, reflections when A's
Fresnel is stochastic)."""

from __future__ import annotations

from html import escape
from typing import TYPE_CHECKING

from volcaustics.reports.presenting.page.parts import num as _num
from volcaustics.reports.presenting.page.parts import verdict as _verdict

if TYPE_CHECKING:
    from volcaustics.reports.presenting.page.report_document import PageDecomposition, ScenePage

OVERVIEW_HEAD = "<th class='l'>caustic error by cause:<br>relMSE parts (% points, debiased)</th>"


def _hundred(value: float) -> float:
    return 100.0 * value  # NaN (a number the store holds as null) stays NaN: drawn as "–"


def overview_cell(page: ScenePage, component: str) -> str:
    """The caustic row's cell: every term's debiased part but those exactly 0 (both numbers),
    then the residual's verdict; an empty cell for the other components (the decomposition
    is the caustic's)."""
    d = page.decomposition
    if component != "caustic":
        return "<td class='l'></td>"
    parts = "<br>".join(f"{escape(t.term.replace('_', ' '))} "
                        f"{_num(_hundred(t.relmse_part_debiased), '{:+.2f}')}" for t in d.terms
                        if not (t.energy_share == 0.0 and t.relmse_part == 0.0))
    res = d.residual
    closes = _verdict(res.within_noise, "closes" if res.within_noise else "does not close")
    return f"<td class='l note'>{parts}<br>{closes}</td>"


def decomposition_table(d: PageDecomposition) -> str:
    """A scene's terms: energy share, relMSE part and its debiased value (± SE), with the
    residual's verdict and message."""
    rows = "".join(f"<tr><td class='l'>{t.term.replace('_', ' ')}</td>"
                   f"<td>{_num(_hundred(t.energy_share), '{:+.1f}%')} ± "
                   f"{_num(_hundred(t.energy_share_se), '{:.1f}')}</td>"
                   f"<td>{_num(_hundred(t.relmse_part), '{:.2f}')} ± "
                   f"{_num(_hundred(t.relmse_part_se), '{:.2f}')}</td>"
                   f"<td>{_num(_hundred(t.relmse_part_debiased), '{:+.2f}')}</td></tr>"
                   for t in (*d.terms, d.total))
    res = d.residual
    text = (f"residual {'within' if res.within_noise else 'NOT within'} noise (energy z "
            f"{_num(res.energy_z, '{:+.1f}', '±∞')}, relMSE z {_num(res.relmse_z, '{:+.1f}', '±∞')})")
    verdict = _verdict(res.within_noise, text)
    msg = f"<p class='warn'>{escape(res.message)}</p>" if res.message else ""
    return (f"<table><tr><th class='l'>term</th><th>energy share (% of R) ± SE</th>"
            f"<th>part of the relative MSE (% points) ± SE</th><th>its part less the noise it shares with R − A"
            f"</th></tr>{rows}</table><p>{verdict}</p>{msg}")
