"""Figures and summary tables of a sweep, from its consolidated tables only
(``reports.measuring.results.store.Store.tables``): no computation but grouping and plotting.

Every figure is written as PNG and SVG, with the Okabe–Ito palette (distinguishable
with the common colour-vision deficiencies), axes named with the parameter table's
names and units. Where several parameters vary, a plot over one of them holds the
others at their largest value (the most accurate setting), and says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.approx.params import label as param_label
from volcaustics.experiment.photons import FATES
from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, pyplot, save_figure
from volcaustics.reports.studies.sweep.density_reading import draw_model_vs_depth, has_depth_sweep
from volcaustics.reports.studies.sweep.suffice import CRITERIA, NUMERIC, at_best, field_keys

if TYPE_CHECKING:
    import pandas as pd

LINESTYLES = {"threshold": "-", "peel": "--"}
CLASS_GROUPS = {"true_hit": ("true_hit",), "wrong_surface": ("wrong_surface",), "false_hit": ("false_hit",),
                "missed": ("missed_inside", "missed_medium")}


def _colours(scenes) -> dict:
    return {s: OKABE_ITO[i % len(OKABE_ITO)] for i, s in enumerate(sorted(scenes))}


def _axis(ax, x, values) -> None:
    """Powers-of-two parameters on a log2 axis, ticks at the swept values, plain labels."""
    from matplotlib.ticker import NullFormatter

    ticks = sorted(set(float(v) for v in values))
    if x in ("layers", "iterations", "peak_samples", "photon_res", "light_res") and min(ticks) > 0:
        ax.set_xscale("log", base=2)
    ax.set_xticks(ticks)
    ax.set_xticklabels([f"{t:g}" for t in ticks])
    ax.xaxis.set_minor_formatter(NullFormatter())


def _series(points):
    """(label, colour, linestyle, rows) per scene, layer strategy and changed scene fields
    (another medium is another series)."""
    colours = _colours(points["scene"].unique())
    fields = field_keys(points)
    for key, rows in points.groupby(["scene", "layer_strategy", *fields], sort=True, dropna=False):
        scene, strategy, values = key[0], key[1], key[2:]
        extra = "".join(f", {name} {value:g}" if isinstance(value, float) else f", {name} {value}"
                        for name, value in zip(fields, values))
        yield f"{scene} ({strategy}{extra})", colours[scene], LINESTYLES.get(strategy, ":"), rows


def draw_figures(tables: dict, folder: str, *, varied: Sequence[str]) -> list:
    """Every figure for the sweep's tables; returns the paths written."""
    points = tables.get("points")
    if points is None or len(points) == 0:
        return []
    paths = []
    numeric = [v for v in varied if v in NUMERIC and points[v].nunique() > 1]
    for x in numeric:
        paths += _intersection_vs(tables, points, varied, x, folder)
        paths += _error_vs(points, varied, x, folder)
    paths += _time_vs_error(points, folder)
    paths += _power_budget(tables, points, varied, folder)
    if has_depth_sweep(points):
        paths += draw_model_vs_depth(points, folder)
    return paths


def step_rows(tables: dict, points: pd.DataFrame) -> pd.DataFrame:
    """The segments table's per-step rows of ``points`` with class shares (% of the
    step's segments, CLASS_GROUPS; self re-hits counted by their class beyond)."""
    seg = tables["segments"]
    seg = seg[seg["grouping"] == "step"].copy()
    for name in CLASS_GROUPS:
        count = sum(seg[f"count_{c}"] + seg.get(f"count_beyond_self_rehit_{c}", 0) for c in CLASS_GROUPS[name])
        seg[f"class_{name}"] = 100.0 * count / seg["segments"]
    return seg[seg["point"].isin(points["point"])]


def _intersection_vs(tables, points, varied, x, folder) -> list:
    plt = pyplot()
    chosen, note = at_best(points, varied, x)
    seg = step_rows(tables, chosen)
    steps = sorted(int(s) for s in seg["step"].dropna().unique())
    if not steps:
        return []
    fig, axes = plt.subplots(len(steps), len(CLASS_GROUPS) + 1, figsize=(3.1 * (len(CLASS_GROUPS) + 1),
                                                                         2.4 * len(steps)), squeeze=False)
    for label, colour, style, rows in _series(chosen):
        own = seg[seg["point"].isin(rows["point"])].sort_values(x)  # segments rows carry every parameter
        for i, step in enumerate(steps):
            at = own[own["step"] == step]
            for j, name in enumerate(CLASS_GROUPS):
                axes[i, j].plot(at[x], at[f"class_{name}"], style, color=colour, marker="o", ms=3,
                                label=label if (i, j) == (0, 0) else None)
            axes[i, -1].plot(at[x], 1000.0 * at["abs_dt_p90"], style, color=colour, marker="o", ms=3)
    for i, step in enumerate(steps):
        for j, name in enumerate(CLASS_GROUPS):
            axes[i, j].set_title(f"step {step}: {name}", fontsize=9)
            axes[i, j].set_ylabel("segments (%)")
        axes[i, -1].set_title(f"step {step}: |Δt| p90 of true hits", fontsize=9)
        axes[i, -1].set_ylabel("|Δt| p90 (mm)")
    for ax in axes[-1]:
        ax.set_xlabel(param_label(x))
    for ax in axes.flat:
        _axis(ax, x, chosen[x])
    fig.legend(loc="upper center", ncol=4, fontsize=8, bbox_to_anchor=(0.5, 1.02))
    fig.suptitle(f"Intersection classes and |Δt| vs {x}" + (f" ({note})" if note else "")
                 + "; self re-hits counted by their class beyond the re-hit surface", y=1.06, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, folder, f"intersection_vs_{x}")




def _error_vs(points, varied, x, folder) -> list:
    """Two panels: the caustic's debiased relative MSE (what a user sees, all causes) and
    the intersection term's own relative MSE (what the intersection estimate costs)."""
    plt = pyplot()
    chosen, note = at_best(points, varied, x)
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.2))
    for ax, (column, label) in zip(axes, CRITERIA.items()):
        for name, colour, style, rows in _series(chosen):
            rows = rows.sort_values(x)
            se = 100.0 * rows["caustic_relmse_se"].fillna(0) if column == "caustic_relmse_debiased" else None
            ax.errorbar(rows[x], 100.0 * rows[column], yerr=se, fmt=style, color=colour, marker="o", ms=3,
                        capsize=2, label=name)
        ax.set_xlabel(param_label(x))
        ax.set_ylabel(label)
        _axis(ax, x, chosen[x])
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle(f"Caustic error and intersection error vs {x}" + (f" ({note})" if note else ""), fontsize=10)
    fig.tight_layout()
    return save_figure(fig, folder, f"caustic_error_vs_{x}")


def pareto_front(times: np.ndarray, errors: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both frame time and error, by time."""
    order = np.lexsort((errors, times))
    front, best = [], np.inf
    for i in order:
        if errors[i] < best:
            front.append(i)
            best = errors[i]
    return np.asarray(front, int)


COSTS = {"frame_time_s": "frame time (s, this machine; contended when several workers ran)",
         "map_reads_per_frame": "map reads per frame (texels the search read; hardware-independent)"}


def _time_vs_error(points, folder) -> list:
    """Caustic error against both costs: llvmpipe frame time and map reads."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(COSTS), figsize=(11.5, 4.2), squeeze=False)
    colours = _colours(points["scene"].unique())
    for ax, (cost, xlabel) in zip(axes[0], COSTS.items()):
        for scene, rows in points.groupby("scene"):
            t = rows[cost].to_numpy(float) if cost in rows else np.full(len(rows), np.nan)
            e = 100.0 * rows["caustic_relmse_debiased"].to_numpy(float)
            ax.scatter(t, e, s=12, color=colours[scene], alpha=0.6, label=scene)
            front = pareto_front(t, e)
            ax.step(t[front], e[front], where="post", color=colours[scene], lw=1.5)
        ax.set_xlabel(xlabel, fontsize=8)
        ax.set_ylabel("caustic relative MSE, debiased (%)")
        ax.grid(alpha=0.3)
    fig.suptitle("Cost vs caustic error; lines: the Pareto front per scene", fontsize=10)
    axes[0, -1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return save_figure(fig, folder, "time_vs_error")


def _power_budget(tables, points, varied, folder) -> list:
    """Power by fate per step at each scene's most accurate point, both tracers."""
    plt = pyplot()
    photons = tables["photons"]
    numeric = [v for v in varied if v in NUMERIC]
    scenes = sorted(points["scene"].unique())
    fig, axes = plt.subplots(1, len(scenes), figsize=(3.0 * len(scenes), 3.4), squeeze=False, sharey=True)
    for ax, scene in zip(axes[0], scenes):
        rows = points[points["scene"] == scene]
        if numeric:
            rows = rows.sort_values(numeric, ascending=False)
        point = rows.iloc[0]["point"]
        budget = photons[photons["point"] == point]
        width = 0.4
        for k, tracer in enumerate(("approx", "exact")):
            b = budget[budget["tracer"] == tracer].sort_values("step")
            bottom = np.zeros(len(b))
            for f, fate in enumerate(FATES):
                values = 100.0 * b[f"share_{fate}"].to_numpy(float)
                ax.bar(b["step"].to_numpy(float) + (k - 0.5) * width, values, width, bottom=bottom,
                       color=OKABE_ITO[f], hatch="" if tracer == "approx" else "//", edgecolor="white",
                       label=f"{fate} ({tracer})" if ax is axes[0, 0] else None)
                bottom += values
        ax.set_title(scene, fontsize=9)
        ax.set_xlabel("steps (interaction step)")
    axes[0, 0].set_ylabel("power, % of step 1's")
    fig.legend(loc="upper center", ncol=4, fontsize=7, bbox_to_anchor=(0.5, 1.08))
    fig.suptitle("Power by fate per step, approximation (plain) and exact replay (hatched), at each scene's "
                 "most accurate point", y=1.14, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, folder, "power_budget")


