"""The report's first screen: the answer before the tables. One chart of every scene's
caustic error split into its causes (the decomposition's debiased parts, stacked, with the
mean image's debiased relative MSE marked and one frame's beside it), and the parameters
the scenes share, stated once (each scene's row then lists only what differs)."""

from __future__ import annotations

from html import escape

from volcaustics.metrics.decomposition import TERMS
from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, png_bytes, pyplot
from volcaustics.reports.presenting.page.charts import signed_stack

FRAME_COLOUR = "#555555"


def _number(value) -> float:
    return 0.0 if value is None else 100.0 * value  # a part the store holds as null: drawn as 0


def error_by_cause_chart(summary: dict) -> bytes:
    """Per scene two bars: the mean image's caustic relMSE split into the decomposition's
    debiased parts (stacked; negative parts leftwards) with the mean's own debiased relMSE
    marked, and below it one frame's relMSE (what a viewer sees), in % points."""
    plt = pyplot()
    scenes = summary["scenes"]
    fig, ax = plt.subplots(figsize=(7.2, 0.62 * len(scenes) + 1.1))
    colours = [OKABE_ITO[i] for i in range(len(TERMS))]
    labels, ticks = [], []
    for row, page in enumerate(scenes):
        y = -1.5 * row
        d = page.get("decomposition") or {}
        terms = {t["term"]: t for t in d.get("terms", [])}
        parts = [_number(terms.get(t, {}).get("relmse_part_debiased")) for t in TERMS]
        signed_stack(ax, y, parts, colours, [t.replace("_", " ") for t in TERMS] if row == 0 else [None] * len(TERMS),
                      lambda v: f"{v:+.1f}")
        caustic = page["components"]["caustic"]
        mean = caustic["relative_mse"].get("debiased")
        if mean is not None:
            ax.plot([100.0 * mean], [y], marker="D", color="black", markersize=4,
                    label="mean image (debiased)" if row == 0 else None)
        frame = (caustic.get("frame_relative_mse") or {}).get("debiased")
        if frame is not None:
            ax.barh(y - 0.55, 100.0 * frame, 0.3, color=FRAME_COLOUR, label="one frame" if row == 0 else None)
            ax.text(100.0 * frame, y - 0.55, f" {100.0 * frame:.1f}", va="center", fontsize=6.5)
        ticks.append(y - 0.2)
        labels.append(page["scene"])
    ax.set_yticks(ticks, labels, fontsize=8)
    ax.axvline(0, color="black", lw=0.5)
    ax.set_xlabel("caustic relative MSE (% points): its parts by cause, the mean image's total (◆), one frame (grey)",
                  fontsize=7)
    ax.tick_params(axis="x", labelsize=7)
    fig.legend(loc="upper center", ncol=4, fontsize=6.5, bbox_to_anchor=(0.5, 1.0), frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    return png_bytes(fig)


def shared_params(summary: dict) -> dict:
    """The shown parameters every scene has with the same value (name → value)."""
    pages = summary["scenes"]
    if not pages:
        return {}
    first = pages[0]["shown_params"]
    return {k: v for k, v in first.items() if all(p["shown_params"].get(k) == v for p in pages[1:])}


def own_params(page: dict, shared: dict) -> dict:
    """A scene's shown parameters less those every scene shares (its size always)."""
    return {k: v for k, v in page["shown_params"].items() if k in ("width", "height") or k not in shared}


def shared_params_line(shared: dict) -> str:
    if not shared:
        return ""
    text = ", ".join(f"{escape(k)} {escape(str(v))}" for k, v in shared.items() if k not in ("width", "height"))
    return f"<p class='note' id='shared-params'>Every scene: {text}.</p>"
