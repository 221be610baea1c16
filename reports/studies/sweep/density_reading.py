"""A density sweep's reading: the approximation's own error and the
single-scattering model's against the medium's optical depth, per scene, and the
optical depth where the model's error overtakes the approximation's.

Both are debiased relative MSEs: the approximation's against the reference of the
paper's model, the model's own (a perfect single-scattering renderer) against K
scattering orders (``metrics.model_term``)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, pyplot, save_figure

COMPONENTS = ("caustic", "combined")


def has_depth_sweep(points: pd.DataFrame) -> bool:
    """Whether ``points`` vary the optical depth within a scene and hold the model term."""
    if len(points) == 0 or "optical_depth" not in points or "model_combined_relmse_own" not in points:
        return False
    varied = points.groupby("scene")["optical_depth"].nunique().max() > 1
    return bool(varied and points["model_combined_relmse_own"].notna().any())


def _series(points: pd.DataFrame, scene: str, component: str) -> tuple:
    """(optical depth, approximation's error, model's error, model's SE), by depth, for
    points where both are known."""
    rows = points[points["scene"] == scene].sort_values("optical_depth")
    approx, model = rows[f"{component}_relmse_debiased"], rows[f"model_{component}_relmse_own"]
    ok = approx.notna() & model.notna()
    return (rows["optical_depth"][ok].to_numpy(float), approx[ok].to_numpy(float), model[ok].to_numpy(float),
            rows[f"model_{component}_relmse_own_se"][ok].fillna(0).to_numpy(float))


def crossing(depth: np.ndarray, approx: np.ndarray, model: np.ndarray) -> float | None:
    """The optical depth where the model's error first exceeds the approximation's: the
    first sign change of model − approx, interpolated linearly in log depth; the first
    depth if the model is already larger there; None if it never is."""
    diff = np.asarray(model) - np.asarray(approx)
    if len(diff) == 0 or not (diff > 0).any():
        return None
    i = int(np.argmax(diff > 0))
    if i == 0:
        return float(depth[0])
    a, b = math.log(depth[i - 1]), math.log(depth[i])
    return float(math.exp(a + (b - a) * (-diff[i - 1]) / (diff[i] - diff[i - 1])))


def crossings(points: pd.DataFrame) -> pd.DataFrame:
    """Per scene and component: the optical depth where the model's error overtakes the
    approximation's (NaN: not within the swept depths), and the depths swept."""
    rows = []
    for scene in sorted(points["scene"].unique()):
        for component in COMPONENTS:
            depth, approx, model, _ = _series(points, scene, component)
            at = crossing(depth, approx, model) if len(depth) else None
            rows.append({"scene": scene, "component": component, "overtakes_at_optical_depth": at,
                         "depth_min": float(depth.min()) if len(depth) else None,
                         "depth_max": float(depth.max()) if len(depth) else None})
    return pd.DataFrame(rows)


def draw_model_vs_depth(points: pd.DataFrame, folder: str) -> list:
    """One panel per component: the approximation's error (solid) and the model's own
    (dashed, ±SE) against optical depth, a colour per scene, the crossing marked."""
    plt = pyplot()
    scenes = sorted(points["scene"].unique())
    fig, axes = plt.subplots(1, len(COMPONENTS), figsize=(11.5, 4.2))
    for ax, component in zip(axes, COMPONENTS):
        for k, scene in enumerate(scenes):
            colour = OKABE_ITO[k % len(OKABE_ITO)]
            depth, approx, model, se = _series(points, scene, component)
            if not len(depth):
                continue
            ax.plot(depth, 100 * np.clip(approx, 1e-6, None), "-o", color=colour, ms=3,
                    label=f"{scene}: approximation")
            ax.errorbar(depth, 100 * np.clip(model, 1e-6, None), yerr=100 * se, fmt="--s", color=colour, ms=3,
                        capsize=2, label=f"{scene}: single-scattering model")
            at = crossing(depth, approx, model)
            if at is not None:
                ax.axvline(at, color=colour, alpha=0.4, lw=1)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("optical depth σ̄t · (light → target → eye)")
        ax.set_ylabel(f"{component}: relative MSE, debiased (%)")
        ax.grid(alpha=0.3, which="both")
    axes[-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle("The approximation's error (against single scattering) and the single-scattering model's own "
                 "(against K orders); vertical lines: where the model's error overtakes", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, folder, "model_vs_optical_depth")
