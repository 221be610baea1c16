"""Photons: the frames' photons replayed exactly with the same random numbers, steps and
Fresnel; power by fate per step for both tracers and where each path first leaves its
replay (``metrics.paths``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.approx.splat_modes import splat_mode
from volcaustics.metrics.paths import FATES as FATE_OF_STATUS
from volcaustics.metrics.paths import path_divergence, power_budget
from volcaustics.reference.oracle import exact_photon_records

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Frame
    from volcaustics.reference.oracle import Oracle
    from volcaustics.scenes.model import Scene

FATES = tuple(FATE_OF_STATUS.values())   # the power budget's share_<fate> columns, in order


def replay(scene: Scene, p: ApproxParams, frame: Frame, seed: int, oracle: Oracle) -> list:
    """The frame's photons replayed exactly with its steps and Fresnel."""
    return exact_photon_records(scene, frame.records[0], steps=p.steps, seed=seed, fresnel=p.fresnel, oracle=oracle,
                                beams=splat_mode(p).beams, splits=p.fresnel_splits, slots=p.photon_res**2)


def photon_rows(frames: Sequence[Frame], replays: list, columns: dict) -> tuple:
    """Power budget per (tracer, step), the shares averaged over seeds, and the paths'
    first divergence per step (all seeds' photons pooled)."""
    budgets: dict = {}
    for tracer, runs in (("approx", [f.records for f in frames]), ("exact", replays)):
        per_seed = [power_budget(r, tracer=tracer) for r in runs]
        for rows in per_seed:
            for row in rows:
                budgets.setdefault((tracer, row["step"]), []).append(row)
    divergence = [path_divergence(f.records, e) for f, e in zip(frames, replays)]
    first = np.concatenate([d["step"] for d in divergence])
    cause = np.concatenate([d["cause"] for d in divergence])
    distance = np.concatenate([d["distance"] for d in divergence])
    drift = np.concatenate([d["power_drift"] for d in divergence])
    steps = frames[0].params["steps"]
    out = []
    for (tracer, step), rows in budgets.items():
        if step == "after":
            continue
        row = {"tracer": tracer, "step": step}
        for key in rows[0]:
            if key.startswith("share_"):
                row[key] = float(np.mean([r[key] for r in rows]))
        alive = [r["share_alive"] for r in budgets[(tracer, "after")]] if step == steps else None
        row["share_alive_after_last"] = float(np.mean(alive)) if alive else float("nan")
        if tracer == "approx":
            at = first == step
            row["photons"] = int(len(first))
            row["diverged_fate"] = _share(at & (cause == "fate"))
            row["diverged_place"] = _share(at & (cause == "place"))
            row["drift_distance_median"] = _median(distance[at])
            row["drift_distance_p90"] = _percentile(distance[at], 90)
            row["power_drift_median"] = _median(drift[at])
        row.update(columns)
        out.append(row)
    summary = {"photons": int(len(first)), "never_diverged": _share(first == 0),
               "first_divergence_by_step": {int(k): _share(first == k) for k in range(1, steps + 1)},
               "place_tolerance_m": divergence[0]["options"]["place_tolerance"]}
    return sorted(out, key=lambda r: (r["tracer"], r["step"])), summary


def _share(mask) -> float:
    """The share of photons ``mask`` holds; NaN (no warning) when there are none: a scene
    whose light reaches no glass."""
    return float(np.mean(mask)) if len(mask) else float("nan")


def _median(v):
    return _percentile(v, 50)


def _percentile(v, q):
    v = np.asarray(v, np.float64)
    v = v[np.isfinite(v)]
    return float(np.percentile(v, q)) if len(v) else float("nan")
