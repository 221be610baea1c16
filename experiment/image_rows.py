"""Images: each colour component of the frames against the reference
(``metrics.image``, ``metrics.noise``), one row per (component, metric).

* ``relative_mse``: value = raw relative MSE of the seeds' mean; debiased = less the
  reference's floor and the approximation's own noise over seeds
  (``approx_noise_removed``), with its standard error and Student-t interval;
* ``frame_relative_mse``: the error one frame shows (``metrics.frame``): value = the
  mean over frames of each frame's relative MSE; debiased = less the reference's
  floor (the bias and one frame's noise remain), with its standard error over the
  frames and R's noise;
* ``per_pixel_relative_mse``, ``ssim``, ``hdr_flip``, ``delta_e2000``: value = the mean
  over frames of one frame's metric; debiased = less the reference's floor (its value
  for the reference against a noisy copy of itself; for SSIM, 1 − SSIM less
  1 − floor): one frame's own noise remains; bootstrap interval of the mean;
* ``energy_ratio``: Σ approx / Σ reference per channel, averaged, of the seeds' mean
  (unbiased: debiased = value); ``reference_sigma``: the reference total's relative σ
  (its Σ var scaled by the reference's measured total_variance_ratio: a light
  tracer's pixels covary); bootstrap interval over the frames' ratios.

A metric that cannot be computed (a reference black in some channel) gets NaN and a
``note``.

Every metric is an entry of :data:`METRICS`, registered by name with
:func:`register_metric` (:func:`per_frame_metric` builds the common kind: one frame's
value, averaged, less the reference's floor); ``docs/howto/add-metric.md`` walks through
adding one.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Callable, Protocol

import numpy as np

from volcaustics.experiment.result import HEADLINE_COLUMNS
from volcaustics.experiment.versions import code_version
from volcaustics.infra.storage import (
    CacheError,
    atomic_write_text,
    cache_dir,
    cache_path,
    document_sha256,
    note_not_cached,
    read_json_object,
)
from volcaustics.metrics import image as im
from volcaustics.metrics.frame import frame_relative_mse
from volcaustics.metrics.noise import noisy_copy, seed_mean_interval, seed_relative_mse, total_sigma
from volcaustics.scenes.formats import COLOUR_LAYERS, MASK_LAYER

if TYPE_CHECKING:
    from volcaustics.reference.cache import ReferenceResult

    class _Imaged(Protocol):
        """A frame as the image metrics read it (``approx.renderer.Frame``, or another
        renderer's images): layer name → H×W×3."""

        @property
        def images(self) -> dict: ...

FLOOR_SEAL = "sha256"  # a floor file's field holding the SHA-256 of the rest of it

RESAMPLES = 2000             # bootstrap resamples over the seeds (per-frame metrics)
FLOOR_DRAWS = 2              # noisy copies averaged for a non-quadratic metric's floor
LEVEL = 0.95                 # bootstrap interval level
FLOOR_SEED = 12345           # noise draw of the non-quadratic metrics' floors (metrics.noise.noisy_copy)
NAN = float("nan")
IMAGE_COLUMNS = {"value": NAN, "reference_floor": NAN, "approx_noise": NAN, "debiased": NAN,
                 "approx_noise_removed": False, "standard_error": NAN, "ci_low": NAN, "ci_high": NAN,
                 "reference_sigma": NAN, "note": "", "options": "{}"}
_FLOORS: dict = {}


def keep_mask(reference: ReferenceResult, frames: Sequence[_Imaged]) -> np.ndarray:
    """H×W bool: pixels where neither the reference nor any frame sees glass."""
    keep = reference.mean[MASK_LAYER][..., 0] < 0.5
    for f in frames:
        keep &= f.images[MASK_LAYER][..., 0] < 0.5
    return keep


def image_rows(frames: Sequence[_Imaged], reference: ReferenceResult, keep: np.ndarray, columns: dict,
               maps: dict | None = None, components: Sequence[str] = COLOUR_LAYERS,
               metrics: Sequence[str] | None = None) -> tuple:
    """(rows, headline): one row per (component, metric) with the columns of
    IMAGE_COLUMNS and ``columns``; headline: component → metric → the summary's
    numbers (``relative_mse`` with each frame's own value, ``per_seed``). ``maps`` (a
    dict) receives the first frame's error map of each metric with ``error_map`` per component:
    (metric, component) → H×W. ``frames``: objects with ``images`` (layer name → H×W×3)
    holding ``components`` (default every colour layer: an approximation's; ``compare``
    may have only ``combined``); ``metrics``: which of :data:`METRICS` (default all; a gate
    point: those its budgets read)."""
    headline: dict
    rows, headline = [], {}
    for component in components:
        r, rv = reference.mean[component], reference.var[component]
        stack = np.stack([f.images[component] for f in frames])
        head = headline.setdefault(component, {})
        inputs = MetricInputs(r, rv, stack, keep, component, columns["reference_key"],
                              reference.total_variance_ratio(component), maps)
        for metric in tuple(METRICS) if metrics is None else metrics:
            try:
                values = METRICS[metric].measure(inputs)
            except ValueError as exc:  # e.g. a reference black in a channel over the compared pixels
                values = {"note": str(exc)}
            per_seed = values.pop("per_seed", None)
            row = {"component": component, "metric": metric, "term": None, **IMAGE_COLUMNS, **values, **columns}
            rows.append(row)
            head[metric] = {k: row[k] for k in HEADLINE_COLUMNS}
            if per_seed is not None:
                head[metric]["per_seed"] = per_seed
    return rows, headline


@dataclass(frozen=True)
class MetricInputs:
    """What a metric reads for one colour component: the reference's mean ``reference``
    and per-pixel variance ``variance`` (H×W×3), the frames ``frames`` (S×H×W×3), the
    compared pixels ``keep`` (H×W bool), the ``component``'s name, the reference's cache
    key (its floors' cache key), the reference total's variance ratio and ``maps``
    (None, or the dict that receives first-frame error maps)."""

    reference: np.ndarray
    variance: np.ndarray
    frames: np.ndarray
    keep: np.ndarray
    component: str
    reference_key: str
    total_variance_ratio: list | None
    maps: dict | None


@dataclass(frozen=True)
class ImageMetric:
    """A metric of the images table: ``measure`` returns a row's numbers (the keys of
    IMAGE_COLUMNS it fills, plus ``per_seed``: each frame's own value, where the summary
    keeps them); ``error_map``: its first frame's error map is kept and drawn (the
    report's scale for it: ``reports.presenting.figures.scales.SCALES``)."""

    name: str
    measure: Callable[[MetricInputs], dict]
    error_map: bool = False


METRICS: dict[str, ImageMetric] = {}  # name -> metric, in the images table's order


def register_metric(metric: ImageMetric) -> ImageMetric:
    """Add ``metric`` to :data:`METRICS`: every point measures it from then on (a name
    taken is refused: a ValueError)."""
    if metric.name in METRICS:
        raise ValueError(f"an image metric named {metric.name!r} is already registered")
    METRICS[metric.name] = metric
    return metric


def map_metrics() -> tuple[str, ...]:
    """The metrics whose first frame's error map a point keeps (``error_map``)."""
    return tuple(name for name, metric in METRICS.items() if metric.error_map)


def per_frame_metric(name: str, value: Callable, debias: Callable[[float, float], float], *,
                     frames: Callable | None = None, error_map: bool = False) -> ImageMetric:
    """A metric of one frame, averaged over the frames: ``value(reference, frame, mask=,
    full=)`` returns {"value": …, "map": H×W when ``full``, options…}; ``debias(mean,
    floor)`` removes the reference's floor (its value for the reference against a noisy
    copy of itself, :func:`metric_floor`); ``frames(reference, frames, mask=, full=)``,
    when given, computes every frame's at once. Interval: percentile bootstrap of the mean."""
    def measure(x: MetricInputs) -> dict:
        return _per_frame(name, value, debias, frames, error_map, x)

    return ImageMetric(name, measure, error_map)


def _relative_mse(x: MetricInputs) -> dict:
    err = seed_relative_mse(x.reference, x.variance, x.frames, mask=x.keep, level=LEVEL)
    # each frame's own relative MSE, in seed order: what a regression test over seeds compares
    per_seed = [im.relative_mse(x.reference, a, mask=x.keep) for a in x.frames]
    return {"value": err.raw, "reference_floor": err.reference_floor, "approx_noise": err.approx_noise,
            "debiased": err.debiased, "approx_noise_removed": err.seeds >= 2, "standard_error": err.standard_error,
            **_ci(err.interval), "per_seed": per_seed,
            "options": json.dumps({"interval": "jackknife over seeds, Student t", "level": LEVEL,
                                   "pixels": err.pixels})}


def _frame_relative_mse(x: MetricInputs) -> dict:
    err = frame_relative_mse(x.reference, x.variance, x.frames, mask=x.keep, level=LEVEL)
    return {"value": float(np.mean(err.per_seed)), "reference_floor": err.reference_floor, "debiased": err.debiased,
            "standard_error": err.standard_error, **_ci(err.interval),
            "options": json.dumps({"interval": "over the frames and R's noise, Student t", "level": LEVEL})}


def _per_frame(metric, fn, debias, frames, error_map, x: MetricInputs) -> dict:
    r, keep = x.reference, x.keep
    full = {"full": True} if error_map and x.maps is not None else {}  # a map only where one is kept
    if frames is not None:
        results = frames(r, x.frames, mask=keep, **full)
    else:
        results = [fn(r, a, mask=keep, **(full if i == 0 else {})) for i, a in enumerate(x.frames)]
    error = [v.pop("map", None) for v in results][0]
    if x.maps is not None and error is not None:
        x.maps[(metric, x.component)] = error
    floor = metric_floor(metric, x.reference_key, x.component, keep, r, x.variance,
                         lambda a, b: fn(a, b, mask=keep)["value"],
                         frames=frames and (lambda a, bs: [v["value"] for v in frames(a, bs, mask=keep)]))
    stat = seed_mean_interval([v["value"] for v in results], resamples=RESAMPLES, level=LEVEL)
    interval = None if stat["interval"] is None else tuple(debias(v, floor) for v in stat["interval"])
    options = {k: v for k, v in results[0].items() if k != "value"}
    return {"value": stat["mean"], "reference_floor": floor, "debiased": debias(stat["mean"], floor),
            **_ci(interval), "options": json.dumps({**options, "interval": "percentile bootstrap of the mean",
                                                    "resamples": stat["resamples"], "level": LEVEL}, default=float)}


def _energy_ratio(x: MetricInputs) -> dict:
    r, keep = x.reference, x.keep
    mean_ratio = im.energy_ratio(r, x.frames.mean(axis=0), mask=keep)["mean"]
    stat = seed_mean_interval([im.energy_ratio(r, a, mask=keep)["mean"] for a in x.frames], resamples=RESAMPLES,
                              level=LEVEL)
    sigma = float(np.mean(total_sigma(x.variance, mask=keep, ratio=x.total_variance_ratio) / r[keep].sum(axis=0)))
    return {"value": mean_ratio, "debiased": mean_ratio, "reference_sigma": sigma, **_ci(stat["interval"]),
            "options": json.dumps({"channels": "per-channel ratios averaged", "interval": "percentile bootstrap",
                                   "resamples": stat["resamples"], "level": LEVEL})}


# the built-in metrics, in the images table's order
IMAGE_METRICS = tuple(register_metric(m).name for m in (
    ImageMetric("relative_mse", _relative_mse),
    ImageMetric("frame_relative_mse", _frame_relative_mse),
    per_frame_metric("per_pixel_relative_mse", im.per_pixel_relative_mse, lambda m, f: m - f, error_map=True),
    per_frame_metric("ssim", im.ssim, lambda m, f: 1.0 - ((1.0 - m) - (1.0 - f))),
    per_frame_metric("hdr_flip", im.hdr_flip, lambda m, f: m - f, frames=im.hdr_flip_frames, error_map=True),
    per_frame_metric("delta_e2000", im.delta_e2000, lambda m, f: m - f, frames=im.delta_e2000_frames),
    ImageMetric("energy_ratio", _energy_ratio)))


def _ci(interval) -> dict:
    return {"ci_low": interval[0] if interval else NAN, "ci_high": interval[1] if interval else NAN, "level": LEVEL}


@lru_cache(maxsize=None)
def floor_code_version() -> str:
    """The code a floor depends on: ``metrics`` and this module. Not the renderers' (a
    floor is the reference against its own noisy copy), so a change to a shader or the
    exact replay keeps every floor."""
    with open(__file__, "rb") as fh:
        return code_version(("metrics",)) + hashlib.sha256(fh.read()).hexdigest()[:16]


def metric_floor(metric: str, reference_key: str, component: str, keep: np.ndarray, r: np.ndarray, rv: np.ndarray,
                 compute: Callable[[np.ndarray, np.ndarray], float], *,
                 frames: Callable[[np.ndarray, np.ndarray], list] | None = None) -> float:
    """A non-quadratic metric's value for the reference against its noisy copy
    (``metrics.noise.noisy_copy``, the mean over FLOOR_DRAWS draws), cached in-process
    and on disk per (reference, component, metric, compared pixels, :func:`floor_code_version`);
    a damaged file on disk is recomputed (:func:`_cached_floor`). ``compute(r, copy)``
    gives one draw's value; ``frames(r, copies)``, when given, every draw's at once."""
    ident = hashlib.sha256(f"{reference_key}/{component}/{metric}/{FLOOR_SEED}/{FLOOR_DRAWS}/"
                           f"{floor_code_version()}/".encode() + np.packbits(keep).tobytes()).hexdigest()[:24]
    if ident in _FLOORS:
        return _FLOORS[ident]
    value = _cached_floor(os.path.join(cache_path("metric-floors"), ident + ".json"), ident)
    if value is None:
        copies = [noisy_copy(r, rv, seed=FLOOR_SEED + i) for i in range(FLOOR_DRAWS)]
        value = float(np.mean(frames(r, np.stack(copies)) if frames else [compute(r, c) for c in copies]))
        if math.isfinite(value):
            doc = {"value": value, "ident": ident, "metric": metric, "component": component,
                   "reference_key": reference_key}
            doc[FLOOR_SEAL] = document_sha256(doc, FLOOR_SEAL)
            try:
                atomic_write_text(os.path.join(cache_dir("metric-floors"), ident + ".json"),
                                  json.dumps(doc, allow_nan=False))
            except CacheError as exc:  # a read-only cache: computed again next time
                note_not_cached(exc, "metric noise floors")
    _FLOORS[ident] = value
    return value


def _seal_of(doc: dict) -> str | None:
    try:
        return document_sha256(doc, FLOOR_SEAL)
    except ValueError:  # NaN or ∞ in it: no canonical JSON
        return None


def _cached_floor(path: str, ident: str) -> float | None:
    """The floor stored in ``path`` if it is the entry ``ident`` and a finite number,
    else None (recomputed): a floor of NaN, ∞, a string, garbage, another entry's
    file or a value that does not match the file's own SHA-256 (FLOOR_SEAL) is never
    used. Files from before the ``ident`` field or the seal count as damaged."""
    try:
        doc = read_json_object(path)
    except (OSError, ValueError):
        return None
    value = doc.get("value")
    if doc.get("ident") != ident or isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    if doc.get(FLOOR_SEAL) != _seal_of(doc):  # a value edited by hand (or before the seal): recomputed
        return None
    return float(value) if math.isfinite(value) else None
