"""The variants view of a sweep (docs/approx.md: each
point's intersection term beside its cost, the Pareto fronts, and per scene the best
variant at no more map reads per segment than the paper's search.

The intersection term (E_k − A, ``metrics.decomposition``) is what a search changes:
its energy share and its part of the caustic's relative MSE, with standard errors over
seeds; and the step-2 segment classes behind it (wrong surface, missed: % of step-2
segments, ``metrics.intersection``). Costs: ``map_reads_per_segment`` (hardware-
independent, the criterion) and llvmpipe ``frame_time_s`` (reported beside it).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import pandas as pd

from volcaustics.approx.params import PAPER
from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, pyplot, save_figure
from volcaustics.reports.studies.sweep.sweep_figures import pareto_front, step_rows

VARIANT_PARAMS = ("search", "start_rule", "crossing", "layer_strategy", "layers", "peak_samples", "iterations")
POINT_COLUMNS = ("map_reads_per_segment", "frame_time_s", "share_intersection", "share_intersection_se",
                 "intersection_relmse_part", "intersection_relmse_part_se")  # from the points table
VARIANT_NAME = ("layer_strategy", "search", "start_rule", "crossing")
SEARCH_MARKERS = {"bisection": "o", "secant": "s", "dda": "^", "hiz": "D"}


def variant_name(row: Mapping[str, Any] | pd.Series) -> str:
    """layer_strategy / search / start_rule / crossing of a row (a dict or a table row),
    those it has."""
    return " / ".join(str(row[k]) for k in VARIANT_NAME if k in row and row[k] is not None)


def is_variants_sweep(varied: Iterable[str]) -> bool:
    """A sweep varies a variant choice (search, start_rule or crossing)."""
    return bool({"search", "start_rule", "crossing"} & set(varied))


def paper_mask(points: pd.DataFrame) -> pd.Series:
    """Rows at the paper's method: its search, start rule, layers, strategy and budgets."""
    mask = pd.Series(True, index=points.index)
    for name in VARIANT_PARAMS:
        if name in points:
            mask &= points[name] == getattr(PAPER, name)
    return mask


def variant_table(tables: dict) -> pd.DataFrame:
    """One row per point: scene, the variant parameters, POINT_COLUMNS, the step-2
    wrong-surface and missed shares (%), whether it is the
    paper's method (``paper``) and on its scene's Pareto front of |intersection share|
    against map reads per segment (``pareto``)."""
    points = tables["points"]
    step2 = step_rows(tables, points)
    step2 = step2[step2["step"] == 2].set_index("point")
    out = points[["point", "scene", *[p for p in VARIANT_PARAMS if p in points]]].copy()
    for column in POINT_COLUMNS:
        out[column] = points[column] if column in points else np.nan
    out["step2_wrong_surface"] = out["point"].map(step2["class_wrong_surface"])
    out["step2_missed"] = out["point"].map(step2["class_missed"])
    out["paper"] = paper_mask(points)
    out["pareto"] = False
    for _, rows in out.groupby("scene"):
        front = pareto_front(rows["map_reads_per_segment"].to_numpy(float),
                             np.abs(rows["share_intersection"].to_numpy(float)))
        out.loc[rows.index[front], "pareto"] = True
    return out.sort_values(["scene", "map_reads_per_segment"]).reset_index(drop=True)


def best_variants(table: pd.DataFrame) -> pd.DataFrame:
    """Per scene: the paper's point and, at no more map reads per segment than the
    paper's, the variant whose intersection term is smallest in both of its parts — the
    smallest ``worse_ratio``, the larger of ``share_ratio`` (|energy share| against the
    paper's) and ``relmse_ratio`` (relative-MSE part against the paper's): an energy share
    near zero can be errors of both signs cancelling (photons lost against surplus hits),
    which the relative-MSE part does not hide (``role`` "paper" / "best"). Scenes without
    the paper's point are left out."""
    rows = []
    for _, own in table.groupby("scene"):
        paper = own[own["paper"]]
        if paper.empty:
            continue
        paper = paper.iloc[0]
        ratios = pd.DataFrame({
            "share_ratio": own["share_intersection"].abs() / abs(paper["share_intersection"]),
            "relmse_ratio": own["intersection_relmse_part"] / paper["intersection_relmse_part"]})
        ratios["worse_ratio"] = ratios.max(axis=1)
        own = own.join(ratios)
        within = own[own["map_reads_per_segment"] <= paper["map_reads_per_segment"]]
        best = within.loc[within["worse_ratio"].idxmin()]
        for role, row in (("paper", own.loc[paper.name]), ("best", best)):
            rows.append({"role": role, **row.to_dict()})
    return pd.DataFrame(rows)


def draw_variants(table: pd.DataFrame, folder: str) -> list:
    """Per scene: |intersection share| against map reads per segment and against frame
    time, a marker per search, filled for start rule `offset`, hollow for the others,
    larger with a thick edge for crossing `surface`; the Pareto front (map reads) drawn,
    the paper's point circled. Returns the paths."""
    plt = pyplot()
    paths = []
    colours = {s: OKABE_ITO[i % len(OKABE_ITO)] for i, s in enumerate(SEARCH_MARKERS)}
    for scene, rows in table.groupby("scene"):
        fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.2))
        for ax, cost, xlabel in ((axes[0], "map_reads_per_segment", "map reads per segment (hardware-independent)"),
                                 (axes[1], "frame_time_s", "frame time (s, llvmpipe)")):
            kinds = [k for k in ("search", "start_rule", "crossing") if k in rows]
            for values, own in rows.groupby(kinds):
                kind = dict(zip(kinds, values))
                colour = colours.get(kind["search"], "grey")
                surface = kind.get("crossing") == "surface"
                ax.scatter(own[cost], 100 * own["share_intersection"].abs(),
                           marker=SEARCH_MARKERS.get(kind["search"], "o"), s=60 if surface else 28,
                           linewidths=2.0 if surface else 1.0, edgecolors=colour,
                           facecolors=colour if kind.get("start_rule") == "offset" else "none",
                           label=" / ".join(str(v) for v in values))
            paper = rows[rows["paper"]]
            ax.scatter(paper[cost], 100 * paper["share_intersection"].abs(), s=160, facecolors="none",
                       edgecolors="black", lw=1.5, label="the paper's method")
            if cost == "map_reads_per_segment":
                front = rows[rows["pareto"]].sort_values(cost)
                ax.step(front[cost], 100 * front["share_intersection"].abs(), where="post", color="black", lw=1,
                        alpha=0.6, label="Pareto front")
            ax.set_xlabel(xlabel, fontsize=8)
            ax.set_ylabel("|intersection term| (% of reference energy)")
            ax.grid(alpha=0.3)
        axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
        fig.suptitle(f"{scene}: intersection term against cost per variant", fontsize=10)
        fig.tight_layout()
        paths += save_figure(fig, folder, f"variants_{scene}")
    return paths
