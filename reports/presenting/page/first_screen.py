"""The report's first screen: the answer before the tables. One chart of every scene's
caustic error split into its causes (the decomposition's debiased parts, stacked, with the
mean image's debiased relative MSE marked and one frame's beside it), and the parameters
the scenes share, stated once (each scene's row then lists only what differs)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from html import escape
from typing import TYPE_CHECKING, NamedTuple

from volcaustics.metrics.decomposition import TERMS
from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, png_bytes, pyplot
from volcaustics.reports.presenting.page.charts import signed_stack

if TYPE_CHECKING:
    from volcaustics.reports.presenting.page.report_document import ScenePage

FRAME_COLOUR = "#555555"


class CauseBar(NamedTuple):
    """One scene's bars on the first chart: the decomposition's debiased relMSE parts in
    ``TERMS`` order, the mean image's debiased relMSE and one frame's (NaN: unknown)."""

    scene: str
    parts: tuple[float, ...]
    mean: float
    frame: float


def cause_bar(page: ScenePage) -> CauseBar:
    caustic = page.components["caustic"]
    terms = {t.term: t.relmse_part_debiased for t in page.decomposition.terms}
    return CauseBar(page.scene, tuple(terms.get(t, math.nan) for t in TERMS),
                    caustic.estimate("relative_mse").debiased, caustic.estimate("frame_relative_mse").debiased)


def _number(value: float) -> float:
    return 0.0 if math.isnan(value) else 100.0 * value  # a part the store holds as null: drawn as 0


def error_by_cause_chart(bars: Sequence[CauseBar]) -> bytes:
    """Per scene two bars: the mean image's caustic relMSE split into the decomposition's
    debiased parts (stacked; negative parts leftwards) with the mean's own debiased relMSE
    marked, and below it one frame's relMSE (what a viewer sees), in % points."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.2, 0.62 * len(bars) + 1.1))
    colours = [OKABE_ITO[i] for i in range(len(TERMS))]
    labels, ticks = [], []
    for row, bar in enumerate(bars):
        y = -1.5 * row
        signed_stack(ax, y, [_number(v) for v in bar.parts], colours,
                     [t.replace("_", " ") for t in TERMS] if row == 0 else [None] * len(TERMS), lambda v: f"{v:+.1f}")
        if not math.isnan(bar.mean):
            ax.plot([100.0 * bar.mean], [y], marker="D", color="black", markersize=4,
                    label="mean image (debiased)" if row == 0 else None)
        if not math.isnan(bar.frame):
            ax.barh(y - 0.55, 100.0 * bar.frame, 0.3, color=FRAME_COLOUR, label="one frame" if row == 0 else None)
            ax.text(100.0 * bar.frame, y - 0.55, f" {100.0 * bar.frame:.1f}", va="center", fontsize=6.5)
        ticks.append(y - 0.2)
        labels.append(bar.scene)
    ax.set_yticks(ticks, labels, fontsize=8)
    ax.axvline(0, color="black", lw=0.5)
    ax.set_xlabel("caustic relative MSE (% points): its parts by cause, the mean image's total (◆), one frame (grey)",
                  fontsize=7)
    ax.tick_params(axis="x", labelsize=7)
    fig.legend(loc="upper center", ncol=4, fontsize=6.5, bbox_to_anchor=(0.5, 1.0), frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    return png_bytes(fig)


def shared_params(pages: Sequence[ScenePage]) -> dict:
    """The shown parameters every scene has with the same value (name → value)."""
    if not pages:
        return {}
    first = pages[0].shown_params
    return {k: v for k, v in first.items() if all(p.shown_params.get(k) == v for p in pages[1:])}


def own_params(page: ScenePage, shared: dict) -> dict:
    """A scene's shown parameters less those every scene shares (its size always)."""
    return {k: v for k, v in page.shown_params.items() if k in ("width", "height") or k not in shared}


def shared_params_line(shared: dict) -> str:
    if not shared:
        return ""
    text = ", ".join(f"{escape(k)} {escape(str(v))}" for k, v in shared.items() if k not in ("width", "height"))
    return f"<p class='note' id='shared-params'>Every scene: {text}.</p>"
