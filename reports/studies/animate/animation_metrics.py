"""An animation's tables: every per-frame image metric as a time series
(``frames.parquet``: the rows of ``experiment.image_rows.image_rows`` with the frame,
its time and the seed mode) and the temporal metrics on frame differences
(``temporal.parquet``: ``metrics.temporal`` per seed mode, component and frame pair).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.experiment.image_rows import image_rows, keep_mask
from volcaustics.metrics.temporal import energy_jitter, flicker, trailing_lag
from volcaustics.scenes.formats import COLOUR_LAYERS, MASK_LAYER

if TYPE_CHECKING:
    from volcaustics.reports.studies.animate.animation_frames import AnimationFrames

NAN = float("nan")
# per-frame series the summary condenses
SUMMARY_METRICS = ("relative_mse", "frame_relative_mse", "hdr_flip", "energy_ratio")
# the components that hold the light tracer's caustic, whose pixels covary: their flicker SE
# takes its batch groups (the camera integrator's fog and direct pixels are independent)
COVARYING = ("caustic", "combined")


def keep_masks(run: AnimationFrames, mode: str) -> np.ndarray:
    """T×H×W: per frame the pixels where neither the reference nor any chain sees glass."""
    masks = run.approx[mode][MASK_LAYER]  # S×T×H×W×1
    return np.stack([keep_mask(ref, [SimpleNamespace(images={MASK_LAYER: m[t]}) for m in masks])
                     for t, ref in enumerate(run.references)])


def frame_rows(run: AnimationFrames) -> list:
    """Per seed mode and frame, every image metric of the chains' frames against that
    frame's reference (the chains are the seeds: their noise is removed with 2 or more)."""
    rows, fps = [], run.scene.animation.fps
    for mode in run.modes:
        keep = keep_masks(run, mode)
        for i, (t, reference) in enumerate(zip(run.frames, run.references)):
            frames = [SimpleNamespace(images={layer: run.approx[mode][layer][c, i] for layer in COLOUR_LAYERS})
                      for c in range(run.chains)]
            columns = {"scene": run.scene.name, "frame": t, "time_s": t / fps, "seed_mode": mode,
                       "chains": run.chains, "reference_key": reference.key,
                       "approx_seconds": run.approx_seconds[i], "reference_seconds": run.reference_seconds[i]}
            rows += image_rows(frames, reference, keep[i], columns, maps={})[0]  # maps: the error maps go
    return rows


class _CausticGroups:
    """Frame t's caustic batch groups and variance, ``metrics.temporal.flicker``'s
    reference_groups, read from its reference when indexed (flicker reads each frame
    once); None for a reference without them."""

    def __init__(self, references):
        self.references = references

    def __len__(self) -> int:
        return len(self.references)

    def __getitem__(self, t: int):
        groups = self.references[t].groups("caustic")
        return None if groups is None else (*groups, self.references[t].var["caustic"])


def temporal_rows(run: AnimationFrames) -> list:
    """Per seed mode, colour component and frame pair: flicker (``metrics.temporal``) and the
    energy ratio's jitter. Consecutive *rendered* frames form the pairs (``--frames`` may
    skip some: ``frame_gap`` says how many animation frames apart they are)."""
    rows = []
    refs = {c: np.stack([r.mean[c] for r in run.references]) for c in COLOUR_LAYERS}
    ref_vars = {c: np.stack([r.var[c] for r in run.references]) for c in COLOUR_LAYERS}
    for mode in run.modes:
        keep = keep_masks(run, mode)
        for component in COLOUR_LAYERS:
            chains = run.approx[mode][component]
            groups = _CausticGroups(run.references) if component in COVARYING else None
            try:
                pairs = flicker(refs[component], ref_vars[component], chains, mask=keep,
                                reference_groups=groups) if len(run.frames) > 1 else []
                energy = energy_jitter(refs[component], ref_vars[component], chains, mask=keep,
                                       ratios=[r.total_variance_ratio(component) for r in run.references])
                note = ""
            except ValueError as exc:  # a black reference over the compared pixels
                pairs, energy, note = [], [], str(exc)
            by_frame = {p.frame: p for p in pairs}
            for i, t in enumerate(run.frames):
                p = by_frame.get(i)
                e = energy[i] if energy else {}
                rows.append({"scene": run.scene.name, "seed_mode": mode, "component": component, "frame": t,
                             "time_s": t / run.scene.animation.fps,
                             "frame_gap": t - run.frames[i - 1] if i else None, "chains": run.chains,
                             "flicker": p.flicker if p else NAN, "flicker_se": p.standard_error if p else NAN,
                             "flicker_z": p.z if p else NAN, "flicker_raw": p.raw if p else NAN,
                             "flicker_reference_noise": p.reference_noise if p else NAN,
                             "flicker_approx_noise": p.test_noise if p else NAN,
                             "flicker_systematic": p.systematic if p else NAN,
                             "energy_ratio": e.get("energy_ratio", NAN), "energy_jitter": e.get("jitter", NAN),
                             "energy_jitter_se": e.get("jitter_se", NAN), "note": note})
    return rows


def summarize(run: AnimationFrames, frames: list, temporal: list) -> dict:
    """Per seed mode and component: mean flicker over the pairs (± the SE of that mean,
    pairs taken as independent), its systematic part, the RMS of the energy ratio's
    jitter, and the per-frame series' mean and worst; times per frame for both renderers."""
    out = {}
    for mode in run.modes:
        per_component = {}
        keep = keep_masks(run, mode) if len(run.frames) >= 3 else None  # what the lag compares
        for component in COLOUR_LAYERS:
            pairs = [r for r in temporal if r["seed_mode"] == mode and r["component"] == component
                     and math.isfinite(r["flicker"])]
            series = {m: [r["debiased"] for r in frames if r["seed_mode"] == mode and r["component"] == component
                          and r["metric"] == m] for m in SUMMARY_METRICS}
            jitter = [r["energy_jitter"] for r in temporal if r["seed_mode"] == mode and r["component"] == component
                      and math.isfinite(r["energy_jitter"])]
            n = len(pairs)
            per_component[component] = {
                "flicker": _mean([r["flicker"] for r in pairs]),
                "flicker_se": math.sqrt(sum(r["flicker_se"] ** 2 for r in pairs)) / n if n else NAN,
                "flicker_systematic": _mean([r["flicker_systematic"] for r in pairs]),
                "flicker_approx_noise": _mean([r["flicker_approx_noise"] for r in pairs]),
                "flicker_max": max((r["flicker"] for r in pairs), default=NAN),
                "energy_jitter_rms": math.sqrt(sum(j * j for j in jitter) / len(jitter)) if jitter else NAN,
                **{f"{m}_mean": _mean(v) for m, v in series.items()},
                **{f"{m}_worst": _worst(m, v) for m, v in series.items()},
                "pairs": n,
                "lag_frames": _lag(run, mode, component, keep),
            }
        out[mode] = per_component
    return out


def _lag(run, mode: str, component: str, keep) -> float:
    """Frames the chains' mean trails the references (``metrics.temporal.trailing_lag``)
    over the pixels ``keep`` (T×H×W; None: too few frames)."""
    if keep is None:
        return NAN
    mean = run.approx[mode][component].mean(axis=0)
    references = np.stack([r.mean[component] for r in run.references])
    return float(trailing_lag(mean, references, mask=keep))


def _worst(metric: str, values) -> float:
    """The largest error of a series: the energy ratio farthest from 1, else the maximum."""
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if not finite:
        return NAN
    return max(finite, key=lambda x: abs(x - 1.0)) if metric == "energy_ratio" else max(finite)


def _mean(values) -> float:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(finite)) if finite else NAN
