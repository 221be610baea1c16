"""One experiment: a scene, the approximation's parameters and a reference → both
renders, the exact replay and every metric (DESIGN.md "Measuring the error").

For each of the approximation's seeds (``params.seed``, +1, …) one frame is rendered
with its segment records. Then:

* **segments**: every searched segment is asked of the exact oracle on the same
  interval and classified (``metrics.intersection``); the start surface's normal of
  a segment is the approximation's hit normal of the step before (unknown at step 1);
* **photons**: the frame's photons are replayed exactly with the same random numbers,
  ``steps`` and ``fresnel`` (``reference.oracle.exact_photon_records``): power by
  fate per step for both tracers, and where each path first leaves its replay
  (``metrics.paths``);
* **images**: each colour component of the frames against the reference
  (``metrics.image``, ``metrics.noise``), and the caustic's error decomposed
  (``metrics.decomposition``) with E_k (the replay above, splatted by the
  approximation's splatter), E_∞ (``EXACT_STEPS`` steps, A's Fresnel and
  stochastic), E_∞,s (small kernel, ``SMALL_SUPERSAMPLE``× pixels box-filtered).

:func:`run_experiment` computes; :func:`write_experiment` writes the tables
(Parquet and CSV), ``decomposition.exr`` and ``summary.json`` (last).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
from dataclasses import dataclass, field

import numpy as np

from volcaustics.metrics.noise import MIN_SEEDS_FOR_INTERVAL
from volcaustics.scenes.formats import COLOUR_LAYERS, MASK_LAYER, STATUS_COLLIDED

EXACT_STEPS = 128            # E_∞: < 0.1% of the power alive after them on every built-in (V6; feline 0.03%)
ALIVE_BUDGET = 1e-3          # above it, summary.json warns that E_∞ is truncated
SMALL_SUPERSAMPLE = 4        # E_∞,s: splatted at 4× and box-averaged (the reference's pixel filter)
SMALL_KERNEL_FINE_PIXELS = 0.6  # its σ in fine pixels (0.15 pixel): aliasing 2·exp(−2π²·0.36) ≈ 0.2%; at 2×
                                # (0.3 pixel) its own blur left sphere2's residual 4σ from 0 (tests/cross/test_v6.py)
TIMED_FRAMES = 3             # frames without records timed per experiment (the median one is reported)
SUBSET_BATCHES = 8           # paired photon subsets per seed of A and the E images: the decomposition's noise
BEYOND_SKIP = 10.0           # a self re-hit's re-query starts this many oracle epsilons past the surface
RESAMPLES = 2000             # bootstrap resamples over the seeds (per-frame metrics)
FLOOR_DRAWS = 2              # noisy copies averaged for a non-quadratic metric's floor
LEVEL = 0.95                 # bootstrap interval level
FLOOR_SEED = 12345           # noise draw of the non-quadratic metrics' floors (metrics.noise.noisy_copy)
SEGMENT_GROUPINGS = (("step", "map", "inside"), ("step", "inside"), ("step",), ())
IMAGE_METRICS = ("relative_mse", "per_pixel_relative_mse", "ssim", "hdr_flip", "delta_e2000", "energy_ratio")
DECOMPOSITION_IMAGES = {"approx": "A", "exact_steps": "E_k", "exact_all_same": "E_inf(A's fresnel)",
                        "exact_all": "E_inf", "exact_all_small": "E_inf,s", "reference": "R"}


class ExperimentError(ValueError):
    """The experiment cannot say anything about this scene (e.g. no caustic reaches the
    pixels it compares); the message names the scene and the reason."""


@dataclass
class Experiment:
    """What :func:`run_experiment` measured: tidy rows and what ``summary.json`` holds,
    the decomposition images (name → H×W×3 float32) for the EXR, and the images a
    report shows (:data:`VIEWS`)."""

    segments: list
    photons: list
    images: list
    summary: dict
    layers: dict = field(default_factory=dict)
    views: dict = field(default_factory=dict)


def parameter_columns(scene, params, seeds: list, reference_key: str) -> dict:
    """The columns every row of every table carries: scene, its hash, every
    approximation parameter (``seed``: the first seed), the seeds, the reference's
    cache key and the code version."""
    from volcaustics.reports.core.versions import code_version

    return {"scene": scene.name, "scene_hash": scene.scene_hash(), **params.to_dict(), "seeds": len(seeds),
            "reference_key": reference_key, "code_version": code_version()}


def _progress(total, enabled):
    from tqdm import tqdm

    return tqdm(total=total, desc="measure", unit="stage", disable=not enabled, leave=False)


def run_experiment(scene, params, *, seeds: int = 1, reference_settings=None, progress: bool = False,
                   renderer=None, oracle=None, reference=None) -> Experiment:
    """Measure the approximation with ``params`` on ``scene`` against its reference.

    Parameters
    ----------
    scene : ``scenes.model.Scene``.
    params : ``approx.ApproxParams`` (width/height unset: the scene camera's).
    seeds : frames with seeds params.seed … params.seed + seeds − 1 (≥ 1; the
        approximation's own noise and the bootstrap intervals need ≥ 2).
    reference_settings : ``reference.settings.ReferenceSettings`` (default: the
        report's, ``reports.defaults.REPORT_REFERENCE``), at the frames' size; rendered
        when not cached.
    renderer, oracle, reference : reused when given (a ``reference.render.ReferenceResult``
        at the frames' size).
    """
    from volcaustics.approx import Renderer
    from volcaustics.approx.params import ParamError
    from volcaustics.approx.trace import check_fits
    from volcaustics.reference.oracle import Oracle

    from volcaustics.reports.core.sizing import REPORT_REFERENCE

    if isinstance(seeds, bool) or not isinstance(seeds, int) or not 1 <= seeds <= 1024:
        raise ParamError(f"seeds = {seeds!r}: expected an integer in [1, 1024]")
    p = params.resolved(scene)
    if p.seed + seeds - 1 > 2**32 - 1:
        raise ParamError(f"seed = {p.seed} with seeds = {seeds}: the last seed exceeds 2^32 − 1")
    seed_list = [p.seed + i for i in range(seeds)]
    check_fits(p, keep_records=True)  # before the reference: a frame that cannot run fails at once
    clock = {}
    bar = _progress(6, progress)
    t0 = time.perf_counter()
    if reference is None:
        from volcaustics.reference.render import render_reference

        settings = dataclasses.replace(reference_settings or REPORT_REFERENCE, width=p.width, height=p.height)
        reference = render_reference(scene, settings, progress=progress)
    clock["reference"] = time.perf_counter() - t0
    bar.update()

    own_renderer = renderer is None
    renderer = renderer or Renderer(scene)
    try:
        t = time.perf_counter()
        oracle = oracle or Oracle(scene)
        clock["oracle"] = time.perf_counter() - t
        t = time.perf_counter()
        frames, timed = _frames(renderer, scene, p, seed_list, warm_up=own_renderer)
        clock["approx"] = time.perf_counter() - t
        bar.update()
        t = time.perf_counter()
        columns = parameter_columns(scene, p, seed_list, reference.key)
        segments = _segment_rows(scene, p, frames, oracle, columns)
        clock["segments"] = time.perf_counter() - t
        bar.update()
        t = time.perf_counter()
        replays = [_replay(scene, p, f, s, oracle) for f, s in zip(frames, seed_list)]
        photons, divergence = _photon_rows(frames, replays, columns)
        clock["photons"] = time.perf_counter() - t
        bar.update()
        t = time.perf_counter()
        exact = _exact_images(scene, p, frames, replays, seed_list, renderer, oracle)
        clock["exact_images"] = time.perf_counter() - t
        bar.update()
    finally:
        if own_renderer:
            renderer.release()
    t = time.perf_counter()
    keep = _keep(reference, frames)
    maps = {}
    image_rows, headline = _image_rows(frames, reference, keep, columns, maps)
    try:
        decomposition = _decompose(exact, reference, keep)
    except ValueError as exc:
        raise ExperimentError(f"{scene.name}: cannot decompose the caustic's error: {exc}") from None
    image_rows += _decomposition_rows(decomposition, columns)
    clock["metrics"] = time.perf_counter() - t
    bar.update()
    bar.close()
    clock["total"] = time.perf_counter() - t0

    summary = _summary(scene, p, seed_list, reference, frames, exact, headline, decomposition, divergence, clock,
                       keep, timed)
    layers = {name: np.asarray(img, np.float32) for name, img in decomposition["images"].items()}
    layers.update({f"term.{name}": np.asarray(img, np.float32) for name, img in decomposition["terms"].items()})
    return Experiment(segments=segments, photons=photons, images=image_rows, summary=summary, layers=layers,
                      views=_views(frames, reference, keep, layers, maps))


VIEWS = {"approx.<component>": "the approximation, mean over the seeds (H×W×3)",
         "reference.<component>": "the reference's mean (H×W×3)",
         "exact_steps": "E_k: the approximation's photons replayed exactly, same steps and Fresnel (caustic)",
         "map.per_pixel_relative_mse.<component>": "per-pixel relative MSE of the first seed's frame (H×W, NaN: "
                                                   "not compared)",
         "map.hdr_flip.<component>": "HDR-FLIP error of the first seed's frame (H×W in [0, 1], NaN: not compared)",
         "compared": "1 where pixels are compared (neither renderer sees glass), else 0 (H×W)"}


def _views(frames, reference, keep, layers, maps) -> dict:
    """The images a report shows (:data:`VIEWS`), float32."""
    out = {}
    for component in COLOUR_LAYERS:
        out[f"approx.{component}"] = np.mean([f.images[component] for f in frames], axis=0)
        out[f"reference.{component}"] = reference.mean[component]
    out["exact_steps"] = layers["exact_steps"]
    for (metric, component), image in maps.items():
        out[f"map.{metric}.{component}"] = image
    out["compared"] = keep
    return {name: np.asarray(image, np.float32) for name, image in out.items()}


# --- approximation frames ----------------------------------------------------------

def _frames(renderer, scene, p, seeds, *, warm_up: bool) -> tuple:
    """One frame per seed, with records, and the pass times of TIMED_FRAMES frames
    rendered as a user would (no records: reading them back is the harness's cost, not
    the method's). A fresh renderer compiles its shaders in its first frame, so it
    renders one frame first that is not timed."""
    if warm_up:
        renderer.render(scene, dataclasses.replace(p, seed=seeds[0]), keep_records=False)
    frames = [renderer.render(scene, dataclasses.replace(p, seed=s), keep_records=True) for s in seeds]
    timed = [renderer.render(scene, dataclasses.replace(p, seed=seeds[i % len(seeds)]), keep_records=False).timings
             for i in range(TIMED_FRAMES)]
    return frames, timed


def _timings(timed: list) -> dict:
    """The pass times of the timed frame with the median frame time (one frame's, so
    its passes add up to at most its frame time)."""
    order = sorted(range(len(timed)), key=lambda i: timed[i]["frame_wall"])
    return {name: float(v) for name, v in timed[order[len(order) // 2]].items()}


# --- segments ----------------------------------------------------------------------

def _start_normals(records: list) -> list:
    """Per step, the approximation's normal at the hit that each segment starts from
    (the step before's hit of the same photon), nan where unknown (step 1, medium)."""
    out = [np.full((len(records[0]), 3), np.nan)]
    for prev, cur in zip(records[:-1], records[1:]):
        normals = np.full((len(cur), 3), np.nan)
        order = np.argsort(prev["photon"])
        keys = prev["photon"][order]
        idx = np.clip(np.searchsorted(keys, cur["photon"]), 0, max(len(keys) - 1, 0))
        if len(keys):
            found = keys[idx] == cur["photon"]
            rows = order[idx[found]]
            normals[found] = np.where(prev["hit"][rows, None], prev["normal"][rows], np.nan)
        out.append(normals)
    return out


def _segment_rows(scene, p, frames, oracle, columns) -> list:
    from volcaustics.approx.light import LightFrustum
    from volcaustics.metrics.intersection import SELF_REHIT, classify_segments, intersection_table
    from volcaustics.scenes.bounds import medium_bounds

    records = np.concatenate([r for f in frames for r in f.records])
    start_normal = np.concatenate([n for f in frames for n in _start_normals(f.records)])
    exact = oracle.first_hits(records["start"], records["direction"], records["search_length"])
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    options = {"texel_angle": 2.0 * frustum.tan_half / p.light_res,
               "light_position": np.asarray(scene.light.position), "start_normal": start_normal}
    first = classify_segments(records, exact, **options)
    beyond = _beyond(records, exact, first["cls"] == SELF_REHIT, oracle)
    classes = classify_segments(records, exact, exact_beyond=beyond, **options)
    rows = []
    for group_by in SEGMENT_GROUPINGS:
        for row in intersection_table(records, classes, group_by=group_by, parameters=columns):
            rows.append({"grouping": ",".join(group_by) or "all", **row})
    return rows


def _beyond(records, exact, self_rehit, oracle) -> dict:
    """The exact first hits beyond each self re-hit's surface (from just past it to
    the end of the searched segment; t from the segment's start), no hit elsewhere."""
    n = len(records)
    out = {"hit": np.zeros(n, bool), "t": np.full(n, np.nan), "normal": np.full((n, 3), np.nan)}
    if not self_rehit.any():
        return out
    start = records["start"][self_rehit].astype(np.float64)
    direction = records["direction"][self_rehit].astype(np.float64)
    skip = exact["t"][self_rehit] + BEYOND_SKIP * oracle.epsilon
    q = oracle.first_hits(start + skip[:, None] * direction, direction,
                          np.maximum(records["search_length"][self_rehit] - skip, 0.0))
    out["hit"][self_rehit] = q["hit"]
    out["t"][self_rehit] = q["t"] + skip
    out["normal"][self_rehit] = q["normal"]
    return out


# --- photons -----------------------------------------------------------------------

def _replay(scene, p, frame, seed, oracle) -> list:
    """The frame's photons replayed exactly with its steps and Fresnel."""
    from volcaustics.reference.oracle import exact_photon_records

    return exact_photon_records(scene, frame.records[0], steps=p.steps, seed=seed, fresnel=p.fresnel, oracle=oracle)


def _photon_rows(frames, replays, columns) -> tuple:
    """Power budget per (tracer, step), the shares averaged over seeds, and the paths'
    first divergence per step (all seeds' photons pooled)."""
    from volcaustics.metrics.paths import path_divergence, power_budget

    budgets = {}
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
            row["diverged_fate"] = float(np.mean(at & (cause == "fate")))
            row["diverged_place"] = float(np.mean(at & (cause == "place")))
            row["drift_distance_median"] = _median(distance[at])
            row["drift_distance_p90"] = _percentile(distance[at], 90)
            row["power_drift_median"] = _median(drift[at])
        row.update(columns)
        out.append(row)
    summary = {"photons": int(len(first)), "never_diverged": float(np.mean(first == 0)),
               "first_divergence_by_step": {int(k): float(np.mean(first == k)) for k in range(1, steps + 1)},
               "place_tolerance_m": divergence[0]["options"]["place_tolerance"]}
    return sorted(out, key=lambda r: (r["tracer"], r["step"])), summary


def _median(v):
    return _percentile(v, 50)


def _percentile(v, q):
    v = np.asarray(v, np.float64)
    v = v[np.isfinite(v)]
    return float(np.percentile(v, q)) if len(v) else float("nan")


# --- exact images --------------------------------------------------------------------

def _small_radius(scene, p) -> float:
    from volcaustics.reports.experiment.exact import pixel_footprint

    return SMALL_KERNEL_FINE_PIXELS * pixel_footprint(scene.camera, p.height * SMALL_SUPERSAMPLE)


def _exact_images(scene, p, frames, replays, seeds, renderer, oracle) -> dict:
    """Per seed, SUBSET_BATCHES paired subset images (``reports.exact.subset_images``)
    of A, E_k, E_∞ (A's Fresnel), E_∞ (stochastic) and E_∞,s; all seeds' batches
    concatenated (batch j of every image: the same emission texels of one seed)."""
    from volcaustics.approx.splat import splats_from_arrays
    from volcaustics.reference.oracle import exact_photon_records

    from volcaustics.reports.experiment.exact import exact_photons, photons_from_records, subset_images

    out = {name: [] for name in ("approx", "exact_steps", "exact_all_same", "exact_all", "exact_all_small")}
    alive = {}
    small = dataclasses.replace(p, splat_radius=_small_radius(scene, p))

    def batches(photons_or_rows, params, supersample=1):
        return subset_images(renderer, photons_or_rows[0], photons_or_rows[1], p.photon_res, SUBSET_BATCHES, params,
                             scene, supersample=supersample)

    for frame, replay, seed in zip(frames, replays, seeds):
        ps = dataclasses.replace(p, seed=seed)
        first = frame.records[0]
        collided = np.concatenate([r[r["status"] == STATUS_COLLIDED] for r in frame.records])
        out["approx"].append(batches((splats_from_arrays(collided["end"], collided["direction"], collided["power"]),
                                      collided["photon"]), ps))
        e_k = photons_from_records(replay, first, ps, steps=p.steps, fresnel=p.fresnel)
        out["exact_steps"].append(batches((e_k.splats, e_k.photon), ps))
        records = exact_photon_records(scene, first, steps=EXACT_STEPS, seed=seed, fresnel=p.fresnel, oracle=oracle)
        same = photons_from_records(records, first, ps, steps=EXACT_STEPS, fresnel=p.fresnel)
        out["exact_all_same"].append(batches((same.splats, same.photon), ps))
        everything = same
        if p.fresnel != "stochastic":
            everything = exact_photons(scene, ps, steps=EXACT_STEPS, fresnel="stochastic", renderer=renderer,
                                       oracle=oracle)
        out["exact_all"].append(batches((everything.splats, everything.photon), ps))
        out["exact_all_small"].append(batches((everything.splats, everything.photon),
                                              dataclasses.replace(small, seed=seed), SMALL_SUPERSAMPLE))
        for fresnel, photons in {p.fresnel: same, "stochastic": everything}.items():
            alive.setdefault(fresnel, []).append(photons.alive_fraction)
    result = {name: np.concatenate(images) for name, images in out.items()}
    return {"batches": result, "alive": alive, "small_radius": small.splat_radius}


# --- image metrics -------------------------------------------------------------------

def _keep(reference, frames) -> np.ndarray:
    """H×W bool: pixels where neither the reference nor any frame sees glass."""
    keep = reference.mean[MASK_LAYER][..., 0] < 0.5
    for f in frames:
        keep &= f.images[MASK_LAYER][..., 0] < 0.5
    return keep


_FLOORS: dict = {}


def _floor(metric, reference_key, component, keep, r, rv, compute) -> float:
    """A non-quadratic metric's value for the reference against its noisy copy
    (``metrics.noise.noisy_copy``, the mean over FLOOR_DRAWS draws), cached in-process
    and on disk per (reference, component, metric, compared pixels, code version)."""
    from volcaustics.scenes.storage import atomic_write_text, cache_dir

    from volcaustics.reports.core.versions import code_version

    ident = hashlib.sha256(f"{reference_key}/{component}/{metric}/{FLOOR_SEED}/{FLOOR_DRAWS}/{code_version()}/"
                           .encode() + np.packbits(keep).tobytes()).hexdigest()[:24]
    if ident in _FLOORS:
        return _FLOORS[ident]
    path = os.path.join(cache_dir("metric-floors"), ident + ".json")
    try:
        with open(path) as fh:
            value = float(json.load(fh)["value"])
    except (OSError, ValueError, KeyError, TypeError):
        from volcaustics.metrics.noise import noisy_copy

        value = float(np.mean([compute(r, noisy_copy(r, rv, seed=FLOOR_SEED + i)) for i in range(FLOOR_DRAWS)]))
        atomic_write_text(path, json.dumps({"value": value, "metric": metric, "component": component,
                                            "reference_key": reference_key}))
    _FLOORS[ident] = value
    return value


NAN = float("nan")
IMAGE_COLUMNS = {"value": NAN, "reference_floor": NAN, "approx_noise": NAN, "debiased": NAN,
                 "approx_noise_removed": False, "standard_error": NAN, "ci_low": NAN, "ci_high": NAN,
                 "reference_sigma": NAN, "note": "", "options": "{}"}


MAP_METRICS = ("per_pixel_relative_mse", "hdr_flip")   # whose first-frame error map a report shows


def _image_rows(frames, reference, keep, columns, maps=None) -> tuple:
    """One row per (component, metric) with the columns of IMAGE_COLUMNS:

    * ``relative_mse``: value = raw relative MSE of the seeds' mean; debiased = less
      the reference's floor and the approximation's own noise over seeds
      (``approx_noise_removed``), with its standard error and Student-t interval;
    * ``per_pixel_relative_mse``, ``ssim``, ``hdr_flip``, ``delta_e2000``: value = the
      mean over frames of one frame's metric; debiased = less the reference's floor
      (its value for the reference against a noisy copy of itself; for SSIM, 1 − SSIM
      less 1 − floor): one frame's own noise remains; bootstrap interval of the mean;
    * ``energy_ratio``: Σ approx / Σ reference per channel, averaged, of the seeds'
      mean (unbiased: debiased = value); ``reference_sigma``: the reference total's
      relative σ (pixels independent); bootstrap interval over the frames' ratios.

    A metric that cannot be computed (a reference black in some channel) gets NaN
    and a ``note``. ``maps`` (a dict) receives the first frame's error map of each
    of MAP_METRICS per component: (metric, component) → H×W."""
    from volcaustics.metrics import image as im
    from volcaustics.metrics.noise import seed_mean_interval, seed_relative_mse

    per_frame = {  # metric: (value of one frame, debias: (mean, floor) -> debiased)
        "per_pixel_relative_mse": (im.per_pixel_relative_mse, lambda m, f: m - f),
        "ssim": (im.ssim, lambda m, f: 1.0 - ((1.0 - m) - (1.0 - f))),
        "hdr_flip": (im.hdr_flip, lambda m, f: m - f),
        "delta_e2000": (im.delta_e2000, lambda m, f: m - f),
    }
    rows, headline = [], {}
    for component in COLOUR_LAYERS:
        r = reference.mean[component]
        rv = reference.var[component]
        stack = np.stack([f.images[component] for f in frames])
        head = headline.setdefault(component, {})

        def add(metric, **values):
            row = {"component": component, "metric": metric, "term": None, **IMAGE_COLUMNS, **values, **columns}
            rows.append(row)
            head[metric] = {k: row[k] for k in ("value", "debiased", "standard_error", "ci_low", "ci_high",
                                                "reference_floor", "approx_noise", "reference_sigma", "note")}

        def measured(metric, compute):
            try:
                compute()
            except ValueError as exc:  # e.g. a reference black in a channel over the compared pixels
                add(metric, note=str(exc))

        def relative_mse():
            err = seed_relative_mse(r, rv, stack, mask=keep, level=LEVEL)
            add("relative_mse", value=err.raw, reference_floor=err.reference_floor, approx_noise=err.approx_noise,
                debiased=err.debiased, approx_noise_removed=err.seeds >= 2, standard_error=err.standard_error,
                **_ci(err.interval), options=json.dumps({"interval": "jackknife over seeds, Student t",
                                                         "level": LEVEL, "pixels": err.pixels}))
            # each frame's own relative MSE, in seed order: what a regression test over seeds compares
            head["relative_mse"]["per_seed"] = [im.relative_mse(r, a, mask=keep) for a in stack]

        measured("relative_mse", relative_mse)
        for metric, (fn, debias) in per_frame.items():
            def one(metric=metric, fn=fn, debias=debias):
                results = [fn(r, a, mask=keep, **({"full": True} if i == 0 and metric in MAP_METRICS else {}))
                           for i, a in enumerate(stack)]
                if maps is not None and "map" in results[0]:
                    maps[(metric, component)] = results[0].pop("map")
                floor = _floor(metric, columns["reference_key"], component, keep, r, rv,
                               lambda x, y: fn(x, y, mask=keep)["value"])
                stat = seed_mean_interval([x["value"] for x in results], resamples=RESAMPLES, level=LEVEL)
                interval = None if stat["interval"] is None else tuple(debias(v, floor) for v in stat["interval"])
                options = {k: v for k, v in results[0].items() if k != "value"}
                add(metric, value=stat["mean"], reference_floor=floor, debiased=debias(stat["mean"], floor),
                    **_ci(interval), options=json.dumps({**options, "interval": "percentile bootstrap of the mean",
                                                         "resamples": stat["resamples"], "level": LEVEL},
                                                        default=float))
            measured(metric, one)

        def energy():
            mean_ratio = im.energy_ratio(r, stack.mean(axis=0), mask=keep)["mean"]
            stat = seed_mean_interval([im.energy_ratio(r, a, mask=keep)["mean"] for a in stack],
                                      resamples=RESAMPLES, level=LEVEL)
            sigma = float(np.mean(np.sqrt(rv[keep].sum(axis=0)) / r[keep].sum(axis=0)))
            add("energy_ratio", value=mean_ratio, debiased=mean_ratio, reference_sigma=sigma, **_ci(stat["interval"]),
                options=json.dumps({"channels": "per-channel ratios averaged", "interval": "percentile bootstrap",
                                    "resamples": stat["resamples"], "level": LEVEL}))

        measured("energy_ratio", energy)
    return rows, headline


def _ci(interval) -> dict:
    return {"ci_low": interval[0] if interval else NAN, "ci_high": interval[1] if interval else NAN, "level": LEVEL}


# --- decomposition -------------------------------------------------------------------

def _decompose(exact, reference, keep) -> dict:
    from volcaustics.metrics.decomposition import decompose_caustic

    return decompose_caustic(exact["batches"], reference.mean["caustic"], keep=keep,
                             reference_var=reference.var["caustic"])


def _decomposition_rows(decomposition, columns) -> list:
    """The decomposition as image rows (component ``caustic``, ``term`` set): per term
    and the total, energy_share, relmse_part, relmse_own with standard errors; the
    noise row's energy_sigma and relmse; the residual's z-scores and verdict."""
    def row(term, metric, value, se=NAN):
        return {"component": "caustic", "metric": metric, "term": term, **IMAGE_COLUMNS, "value": float(value),
                "standard_error": float(se), **columns}

    rows = []
    for r in decomposition["rows"]:
        for metric, value in r.items():
            if metric != "term" and not metric.endswith("_se"):
                rows.append(row(r["term"], metric, value, r.get(f"{metric}_se", NAN)))
    res = decomposition["residual"]
    rows += [row("residual", "energy_z", res["energy_z"]), row("residual", "debiased_relmse", res["debiased_relmse"],
                                                                res["relmse_se"]),
             row("residual", "relmse_z", res["relmse_z"]), row("residual", "within_noise", res["within_noise"])]
    return rows


# --- summary -------------------------------------------------------------------------

def _summary(scene, p, seeds, reference, frames, exact, headline, decomposition, divergence, clock, keep,
             timed) -> dict:
    from volcaustics.approx.context import gl_info, shared_context

    from volcaustics.reports.core.versions import code_version, library_versions

    alive = {k: float(max(v)) for k, v in exact["alive"].items()}
    warnings = [f"E_inf ({k} Fresnel) keeps {100 * v:.2f}% of the power alive after {EXACT_STEPS} steps "
                f"(> {100 * ALIVE_BUDGET:.1f}%): the truncation term is understated" for k, v in alive.items()
                if v > ALIVE_BUDGET]
    if not decomposition["residual"]["within_noise"]:
        warnings.append(decomposition["residual"]["message"])
    if len(seeds) < MIN_SEEDS_FOR_INTERVAL:
        warnings.append(f"{len(seeds)} seed(s): no intervals (they need {MIN_SEEDS_FOR_INTERVAL})"
                        + ("" if len(seeds) >= 2 else "; the approximation's own noise is not estimated, not "
                           "subtracted") + f"; use --seeds {MIN_SEEDS_FOR_INTERVAL} or more")
    m = reference.manifest
    return {
        "kind": "experiment", "scene": scene.name, "scene_hash": scene.scene_hash(),
        "description": scene.description, "params": p.to_dict(), "seeds": len(seeds), "seed_values": seeds,
        "reference": {"key": reference.key, "settings": m.get("settings"), "photons": m.get("photons"),
                      "batches": m.get("batches"), "camera_batches": m.get("camera_batches"),
                      "noise_floor": m.get("noise_floor"), "stopped_by": m.get("stopped_by"),
                      "mitsuba_variant": m.get("mitsuba_variant"), "cached": reference.cached,
                      "reference_code_version": m.get("reference_code_version")},
        "exact": {"steps": EXACT_STEPS, "alive_after": alive, "small_splat_radius": exact["small_radius"],
                  "small_supersample": SMALL_SUPERSAMPLE,
                  "batches": int(len(exact["batches"]["approx"]))},
        "compared_pixels": int(keep.sum()),
        "images": headline,
        "decomposition": {"rows": decomposition["rows"], "residual": decomposition["residual"],
                          "options": decomposition["options"]},
        "paths": divergence,
        "approx_timings_s": _timings(timed), "timed_frames": len(timed), "timing_method": frames[0].timing_method,
        "experiment_seconds": clock, "gl": gl_info(shared_context()),
        "code_version": code_version(), "versions": library_versions(), "warnings": warnings,
    }


# --- writing ---------------------------------------------------------------------------

TABLES = ("segments", "photons", "images")


OUTPUT_FILES = (*(f"{name}.{ext}" for name in TABLES for ext in ("parquet", "csv")), "decomposition.exr",
                "summary.json")  # what `measure -o DIR` writes; the manifest, summary.json, last


def output_paths(out_dir: str) -> dict:
    return {name: os.path.join(out_dir, name) for name in OUTPUT_FILES}


def table(rows: list):
    """Rows as a pandas DataFrame with one type per column: integers with gaps (a
    ``step`` that is None on the rows of all steps) as nullable Int64, text as string."""
    import pandas as pd

    frame = pd.DataFrame(rows)
    for column in frame.columns:
        values = [row.get(column) for row in rows if row.get(column) is not None]
        if values and all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in values):
            frame[column] = frame[column].astype("Int64")
        elif values and all(isinstance(v, str) for v in values):
            frame[column] = frame[column].astype("string")
    return frame


def write_experiment(experiment: Experiment, out_dir: str) -> dict:
    """Write the tables (Parquet + CSV), ``decomposition.exr`` and, last,
    ``summary.json`` into ``out_dir`` as one set (``scenes.storage.atomic_set``: an
    interrupted write leaves the last complete set). Returns the paths."""
    from volcaustics.scenes.imageio import write_exr
    from volcaustics.scenes.storage import atomic_set

    os.makedirs(out_dir, exist_ok=True)
    paths = output_paths(out_dir)  # summary.json last: the set's manifest
    s = experiment.summary
    with atomic_set(list(paths.values())) as temps:
        tmp = dict(zip(paths, temps))
        for name in TABLES:
            frame = table(getattr(experiment, name))
            frame.to_parquet(tmp[f"{name}.parquet"], index=False)
            frame.to_csv(tmp[f"{name}.csv"], index=False)
        write_exr(tmp["decomposition.exr"], experiment.layers,
                  {"volcaustics_scene": s["scene"], "volcaustics_scene_hash": s["scene_hash"],
                   "volcaustics_renderer": "experiment",
                   "volcaustics_layers": json.dumps({**DECOMPOSITION_IMAGES, "term.*": "the decomposition's terms"}),
                   "volcaustics_params": json.dumps(s["params"], sort_keys=True)})
        summary = {**s, "outputs": {k: os.path.abspath(v) for k, v in paths.items()}}
        with open(tmp["summary.json"], "w", encoding="utf-8") as fh:
            fh.write(json.dumps(plain(summary), indent=2, allow_nan=False))
    return paths


def plain(value):
    """``value`` as strict JSON data: numpy scalars and arrays as Python numbers and
    lists, tuples as lists, NaN and ±inf as None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    return value
