"""The small charts of one scene in the accuracy report, drawn from its entry in the
report's document only (``page.report_document.ScenePage``): hit classes by step and layer,
power by fate per step for both tracers, the caustic error decomposition, and the
per-pass times beside the paper's shares. Each returns PNG bytes; colours are
Okabe–Ito and every bar carries its number or a legend entry (not colour alone).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.experiment.photons import FATES
from volcaustics.metrics.decomposition import TERMS
from volcaustics.metrics.intersection import OUTCOME_CLASSES
from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, png_bytes, pyplot

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from volcaustics.reports.presenting.page.report_document import PageDecomposition, PassTiming

CLASS_COLOURS = dict(zip(OUTCOME_CLASSES, ("#009E73", "#E69F00", "#D55E00", "#CC79A7", "#0072B2", "#BBBBBB")))
PASS_COLOURS = {"trace": "#D55E00", "splat": "#0072B2", "layers": "#E69F00", "emission": "#56B4E9",
                "camera": "#CC79A7", "fog": "#009E73", "direct": "#F0E442", "other": "#BBBBBB"}


def hit_classes_chart(hit_classes: Mapping) -> bytes:
    """One panel per step: per light-map layer of the approximation's hit ("none": it
    found none), that layer's segments by class, as % of the step's segments."""
    plt = pyplot()
    rows = hit_classes["rows"]
    steps = sorted({r["step"] for r in rows})
    fig, axes = plt.subplots(1, len(steps), figsize=(2.1 * len(steps) + 0.6, 2.4), squeeze=False, sharey=True)
    for ax, step in zip(axes[0], steps):
        at = [r for r in rows if r["step"] == step]
        x = np.arange(len(at))
        bottom = np.zeros(len(at))
        for name in OUTCOME_CLASSES:
            values = np.array([r[name] for r in at], float)
            ax.bar(x, values, 0.7, bottom=bottom, color=CLASS_COLOURS[name], edgecolor="white", linewidth=0.3,
                   label=name.replace("_", " ") if ax is axes[0, 0] else None)
            bottom += values
        ax.set_xticks(x, [str(r["layer"]) for r in at], fontsize=7)
        ax.set_ylim(0, 100)
        ax.set_title(f"step {step}", fontsize=8)
        ax.set_xlabel("layer (approx. hit)", fontsize=7)
        ax.tick_params(axis="y", labelsize=7)
    axes[0, 0].set_ylabel("% of the step's segments", fontsize=7)
    fig.legend(loc="upper center", ncol=6, fontsize=6.5, bbox_to_anchor=(0.5, 1.1), frameon=False)
    fig.tight_layout()
    return png_bytes(fig)


def power_budget_chart(budget: list) -> bytes:
    """Per step, the power by fate: approximation (plain) and exact replay (hatched),
    as % of the power emitted into step 1; on the last step also the power still
    alive after it."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(4.4, 2.5))
    width = 0.38
    for k, tracer in enumerate(("approx", "exact")):
        rows = sorted((r for r in budget if r["tracer"] == tracer), key=lambda r: r["step"])
        x = np.array([r["step"] for r in rows], float) + (k - 0.5) * width
        bottom = np.zeros(len(rows))
        for f, fate in enumerate(FATES + ("alive_after_last",)):
            values = np.array([r.get(fate) or 0.0 for r in rows], float)   # alive: the last step's only
            ax.bar(x, values, width, bottom=bottom, color=OKABE_ITO[f], hatch="" if tracer == "approx" else "///",
                   edgecolor="white", linewidth=0.3, label=f"{fate.replace('_', ' ')}" if k == 0 else None)
            bottom += values
    ax.set_xticks(sorted({r["step"] for r in budget}))
    ax.set_xlabel("step (left bar: approximation, hatched: exact replay)", fontsize=7)
    ax.set_ylabel("% of step 1's power", fontsize=7)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=6.5, ncol=2, frameon=False)
    fig.tight_layout()
    return png_bytes(fig)


def signed_stack(ax: Axes, y: float, values: Sequence[float], colours: Sequence[str], labels: Sequence[str | None],
                 fmt: Callable[[float], str]) -> None:
    """One horizontal bar: positive parts stacked rightwards from 0, negative ones
    leftwards, each labelled with its number when it is wide enough."""
    span = max(sum(v for v in values if v > 0), -sum(v for v in values if v < 0), 1e-12)
    right = left = 0.0
    for value, colour, label in zip(values, colours, labels):
        start = right if value >= 0 else left + value
        ax.barh(y, abs(value), 0.6, left=start, color=colour, edgecolor="white", linewidth=0.5, label=label)
        if abs(value) > 0.06 * span:
            ax.text(start + abs(value) / 2, y, fmt(value), ha="center", va="center", fontsize=6.5,
                    color="black")
        if value >= 0:
            right += value
        else:
            left += value


def decomposition_chart(decomposition: PageDecomposition) -> bytes:
    """The caustic's error split into its causes: energy shares (% of the reference's
    caustic energy; they sum to 1 − energy ratio) and debiased parts of the relative
    MSE, as the tables give them (they sum to it, less the noise), each a stacked bar
    with its numbers; the total marked."""
    plt = pyplot()
    terms = {t.term: t for t in decomposition.terms}
    colours = [OKABE_ITO[i] for i in range(len(TERMS))]
    number = lambda v: 0.0 if math.isnan(v) else v  # noqa: E731  (a term the store holds as null: drawn as 0)
    fig, axes = plt.subplots(2, 1, figsize=(5.6, 2.3))
    for ax, (key, title, scale) in zip(axes, (("energy_share", "energy share (% of R's caustic energy)", 100.0),
                                             ("relmse_part_debiased",
                                              "part of the relative MSE, debiased (% points)", 100.0))):
        values = [scale * number(getattr(terms[t], key)) for t in TERMS]
        signed_stack(ax, 0, values, colours, [t.replace("_", " ") for t in TERMS] if ax is axes[0] else
                      [None] * len(TERMS), lambda v: f"{v:+.1f}")
        total = scale * number(getattr(decomposition.total, key))
        ax.axvline(total, color="black", lw=1, ls="--")
        ax.text(total, 0.42, f"total {total:+.1f}", fontsize=6.5, ha="left", va="bottom")
        ax.axvline(0, color="black", lw=0.5)
        ax.set_yticks([])
        ax.set_title(title, fontsize=7, loc="left")
        ax.tick_params(labelsize=7)
    fig.legend(loc="upper center", ncol=6, fontsize=6.5, bbox_to_anchor=(0.5, 1.08), frameon=False)
    fig.tight_layout()
    return png_bytes(fig)


def pass_times_chart(timing: PassTiming) -> bytes:
    """Shares of the frame per pass, this run beside the paper's (intersection
    estimation ≈ 70%, splatting ≈ 23% on the authors' GPU)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.6, 1.5))
    measured = {p.name: 100.0 * p.share for p in timing.passes}
    paper = {name: 100.0 * share for name, share in timing.paper_shares.items()}
    for y, shares in ((1, measured), (0, paper)):
        left = 0.0
        for name, value in shares.items():
            ax.barh(y, value, 0.6, left=left, color=PASS_COLOURS.get(name, "#999999"), edgecolor="white",
                    linewidth=0.5, label=name if y == 1 or name not in measured else None)
            if value > 6:
                ax.text(left + value / 2, y, f"{name} {value:.0f}%", ha="center", va="center", fontsize=6.5)
            left += value
    ax.set_yticks([1, 0], ["this run", "paper"], fontsize=7)
    ax.set_xlim(0, 100)
    ax.set_xlabel("% of the frame", fontsize=7)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=6, ncol=8, loc="upper center", bbox_to_anchor=(0.5, 1.45), frameon=False)
    fig.tight_layout()
    return png_bytes(fig)
