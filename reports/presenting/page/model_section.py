"""The page's view of the single-scattering model's own error (``experiment.model_rows``):
an overview cell per component and a table per scene, beside the decomposition."""

from __future__ import annotations

import math
from html import escape
from typing import TYPE_CHECKING

from volcaustics.reports.presenting.page.parts import debiased_pct, num, pct
from volcaustics.reports.presenting.page.report_document import MISSING
from volcaustics.scenes.formats import COLOUR_LAYERS

if TYPE_CHECKING:
    from volcaustics.experiment.result import Estimate, ModelComponent
    from volcaustics.reports.presenting.page.report_document import ScenePage

OVERVIEW_HEAD = "<th>single-scattering model:<br>its relative MSE (energy left out)</th>"


def _numbers(page: ScenePage, component: str) -> ModelComponent | None:
    """The model's numbers on ``component``; None without a model term or where it has a note."""
    if page.model is None:
        return None
    m = next((c for c in page.model.components if c.component == component), None)
    return m if m is not None and not m.note else None


def _e(estimate: Estimate | None) -> Estimate:
    return estimate or MISSING


def overview_cell(page: ScenePage, component: str) -> str:
    """The overview's cell of ``component``: the model's own relative MSE against K orders,
    debiased, and the energy it leaves out; n/a without higher orders."""
    m = _numbers(page, component)
    if m is None:
        return "<td class='note'>n/a</td>"
    return f"<td>{debiased_pct(_e(m.relmse_own).debiased)} ({pct(_e(m.energy_share).value, 1)})</td>"


def larger_error(page: ScenePage, component: str) -> str | None:
    """"model" or "approximation": which error of ``component`` is the larger, the
    model's own relative MSE or the approximation's (both debiased); None if unknown."""
    m = _numbers(page, component)
    approx = page.components[component].estimate("relative_mse").debiased
    own = math.nan if m is None else _e(m.relmse_own).debiased
    if math.isnan(own) or math.isnan(approx):
        return None
    return "model" if own > approx else "approximation"


def model_section(page: ScenePage) -> str:
    """The scene's table: per component the energy K orders add, the model's own relative
    MSE, its part of the approximation's error against R_ms, and the approximation's error
    against the paper's model beside it."""
    model = page.model
    if model is None:
        return ("<h3>The single-scattering model against more orders</h3><p class='note'>The reference was rendered "
                "with single scattering only (max_scatter 1): no model term.</p>")
    rows = []
    notes = {c.component: c.note for c in model.components}
    for component in COLOUR_LAYERS:
        m = _numbers(page, component)
        if m is None:
            note = notes.get(component) or "no numbers"
            rows.append(f"<tr><td class='l'>{component}</td><td colspan=5 class='note'>{escape(note)}</td></tr>")
            continue
        share, own, part = _e(m.energy_share), _e(m.relmse_own), _e(m.relmse_part)
        approx = page.components[component].estimate("relative_mse").debiased
        rows.append(f"<tr><td class='l'>{component}</td>"
                    f"<td>{pct(share.value, 1)} ± {num(100 * share.standard_error, '{:.2f}')}</td>"
                    f"<td>{debiased_pct(own.debiased, se=own.standard_error)}</td>"
                    f"<td>{num(100 * part.value, '{:+.2f}')} ± {num(100 * part.standard_error, '{:.2f}')}</td>"
                    f"<td>{debiased_pct(approx)}</td><td class='l'>{larger_error(page, component) or 'n/a'}</td></tr>")
    more = f"more than {model.max_scatter}"
    needed = ", ".join(f"{c} {more if n is None else n}" for c, n in model.orders_needed.items())
    verdict = "" if model.converged else (" <span class='warn'>Not converged: the last order still changes the "
                                          "total by more than its noise floor.</span>")
    return (f"<h3>The single-scattering model against {model.max_scatter} scattering orders</h3>"
            f"<table><tr><th class='l'>component</th><th>energy the model leaves out (% of R_ms) ± SE</th>"
            f"<th>the model's own relative MSE, debiased ± SE</th><th>its part of A's relative MSE against R_ms "
            f"(% points) ± SE</th><th>A's relative MSE against the model's reference</th><th class='l'>larger error"
            f"</th></tr>{''.join(rows)}</table><p class='note'>Orders the convergence rule needs "
            f"({escape(model.rule)}): {escape(needed)}.{verdict} Paths through diffuse surfaces and "
            f"light → glass → medium → glass → camera are outside both models.</p>")
