"""The best-configuration search's figure: the paper's configuration, the adopted one and
each scene's best side by side, with their decomposition terms."""

from __future__ import annotations

import numpy as np
import pandas as pd

from volcaustics.metrics.decomposition import TERMS
from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, pyplot, save_figure

ROLE_COLOURS = {"paper": OKABE_ITO[7], "adopted": OKABE_ITO[4], "scene best": OKABE_ITO[0]}


def role_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The rows with a role, one per (scene, role): a row holding two roles is listed
    under each."""
    rows = []
    for _, r in table[table["role"].fillna("") != ""].iterrows():
        for role in str(r["role"]).split(", "):
            rows.append({**r.to_dict(), "role": role})
    return pd.DataFrame(rows)


def draw_best(table: pd.DataFrame, folder: str) -> list:
    """``best_configuration``: per scene the caustic's relative MSE and its decomposition
    terms' parts (each term's relMSE part, ``metrics.decomposition``) for the paper's
    configuration, the adopted one and the scene's own best, side by side. Returns the
    paths."""
    rows = role_rows(table)
    if rows.empty:
        return []
    plt = pyplot()
    scenes = list(dict.fromkeys(rows["scene"]))
    fig, axes = plt.subplots(1, len(scenes), figsize=(2.6 * len(scenes) + 1.0, 3.8), sharey=False, squeeze=False)
    labels = ["caustic", *TERMS]
    for ax, scene in zip(axes[0], scenes):
        own = rows[rows["scene"] == scene]
        x = np.arange(len(labels))
        width = 0.8 / max(len(ROLE_COLOURS), 1)
        for k, (role, colour) in enumerate(ROLE_COLOURS.items()):
            r = own[own["role"] == role]
            if r.empty:
                continue
            r = r.iloc[0]
            values = [r["caustic_relmse_debiased"], *(r[f"relmse_{t}"] for t in TERMS)]
            ax.bar(x + (k - 1) * width, 100 * np.asarray(values, float), width, color=colour, label=role)
        ax.axhline(0.0, color="black", lw=0.6)
        ax.set_xticks(x, labels, rotation=60, fontsize=7)
        ax.set_title(scene, fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].set_ylabel("relative MSE or its part (%)")
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle("The paper's configuration, the adopted one and each scene's best at ≤ the paper's frame cost",
                 fontsize=10)
    fig.tight_layout()
    return save_figure(fig, folder, "best_configuration")
