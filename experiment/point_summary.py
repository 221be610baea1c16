"""What an experiment's ``summary.json`` holds, the columns every table row carries, and
the images a report shows (:data:`VIEWS`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, cast

import numpy as np

from volcaustics.approx.context import gl_info, shared_context
from volcaustics.approx.cost import COST_FIELDS, frame_cost
from volcaustics.approx.cost_model import predicted_frames
from volcaustics.experiment.approx_frames import median_timings
from volcaustics.experiment.exact_images import SMALL_SUPERSAMPLE
from volcaustics.experiment.summaries import SCHEMAS, ExperimentSummary
from volcaustics.experiment.versions import code_version, library_versions
from volcaustics.metrics.noise import MIN_SEEDS_FOR_INTERVAL
from volcaustics.reference.served import AS_CACHED, describe_budget, judged
from volcaustics.scenes.fields import field_columns, optical_depth
from volcaustics.scenes.formats import COLOUR_LAYERS

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Frame
    from volcaustics.reference.cache import ReferenceResult
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes.model import Scene

KIND = "experiment"  # summary.json "kind" of a measure output folder

ALIVE_BUDGET = 1e-3          # above it, summary.json warns that E_∞ is truncated
VIEWS = {"approx.<component>": "the approximation, mean over the seeds (H×W×3)",
         "reference.<component>": "the reference's mean (H×W×3)",
         "exact_steps": "E_k: the approximation's photons replayed exactly, same steps and Fresnel (caustic)",
         "map.per_pixel_relative_mse.<component>": "per-pixel relative MSE of the first seed's frame (H×W, NaN: "
                                                   "not compared)",
         "map.hdr_flip.<component>": "HDR-FLIP error of the first seed's frame (H×W in [0, 1], NaN: not compared)",
         "compared": "1 where pixels are compared (neither renderer sees glass), else 0 (H×W)"}


def parameter_columns(scene: Scene, params: ApproxParams, seeds: list, reference_key: str,
                      fields: dict | None = None) -> dict:
    """The columns every row of every table carries: scene, its hash, its optical depth,
    every approximation parameter (``seed``: the first seed), the seeds, the reference's
    cache key, the code version and the scene fields a sweep changed (``fields``)."""
    return {"scene": scene.name, "scene_hash": scene.scene_hash(), "optical_depth": optical_depth(scene),
            **params.to_dict(), "seeds": len(seeds), "reference_key": reference_key, "code_version": code_version(),
            **field_columns(fields)}


def map_reads(frames: Sequence[Frame]) -> dict:
    """Light-map texels the search read (the cost that travels across hardware): per
    frame (mean over the seeds), per searched segment, and per segment at each step."""
    steps = len(frames[0].records)
    reads = [[int(r["map_reads"].sum()) for r in f.records] for f in frames]
    segments = [[len(r) for r in f.records] for f in frames]
    per_step = [sum(x[k] for x in reads) / max(sum(n[k] for n in segments), 1) for k in range(steps)]
    return {"per_frame": float(np.mean([sum(x) for x in reads])),
            "per_segment": sum(map(sum, reads)) / max(sum(map(sum, segments)), 1), "per_step": per_step}


def frame_costs(frames: Sequence[Frame], params: ApproxParams) -> dict:
    """A frame's cost (``approx.cost.frame_cost``: map reads, emission reads, splats and
    their total, photons, segments, fragments per pass), the mean over the seeds' frames."""
    costs = [frame_cost(f.records, params, f.work) for f in frames]
    return {name: float(np.mean([c[name] for c in costs])) for name in COST_FIELDS}


def experiment_views(frames: Sequence[Frame], reference: ReferenceResult, keep: np.ndarray, layers: dict,
                     maps: dict) -> dict:
    """The images a report shows (:data:`VIEWS`), float32."""
    out = {}
    for component in COLOUR_LAYERS:
        out[f"approx.{component}"] = np.mean([f.images[component] for f in frames], axis=0)
        out[f"reference.{component}"] = reference.mean[component]
    if "exact_steps" in layers:  # not measured without the decomposition (the gate's points)
        out["exact_steps"] = layers["exact_steps"]
    for (metric, component), image in maps.items():
        out[f"map.{metric}.{component}"] = image
    out["compared"] = keep
    return {name: np.asarray(image, np.float32) for name, image in out.items()}


def reference_summary(reference: ReferenceResult, request: ReferenceSettings | None = None) -> dict:
    """What a summary says of the reference a result was measured against: the entry
    (``settings``: those it was rendered with) judged against the run's ``request``
    (``reference.served.judged``; None: the request it was rendered for): ``request``,
    ``rendered_for`` (None, or the other request's budget), ``stopped_by`` and
    ``short_of_target`` (component → its floor and the request's target)."""
    m = reference.manifest
    verdict = judged(m, request)
    return {"key": reference.key, "settings": m.get("settings"), "photons": m.get("photons"),
            "batches": m.get("batches"), "camera_batches": m.get("camera_batches"),
            "noise_floor": m.get("noise_floor"), "stopped_by": verdict["stopped_by"],
            "short_of_target": verdict["short_of_target"], "request": verdict["request"],
            "rendered_for": verdict["rendered_for"],
            "mitsuba_variant": m.get("mitsuba_variant"), "cached": reference.cached,
            "reference_code_version": m.get("reference_code_version")}


def reference_warnings(summary: dict) -> list:
    """The warnings a result's reference (``summary``: :func:`reference_summary`) gives:
    its floors above the request's targets, and an entry rendered for another request."""
    out = []
    short, stopped_by = summary["short_of_target"], summary["stopped_by"]
    if short:
        floors = ", ".join(f"{c} {100 * v['noise_floor']:.2f}% (target {100 * v['target']:.2f}%)"
                           for c, v in short.items())
        how = (f"stopped at its {stopped_by} above its noise target" if stopped_by != AS_CACHED else
               "was served from the cache as it is, above this run's noise target")
        out.append(f"the reference {how}: {floors}; its noise is debiased, but the numbers are less precise than "
                   f"asked (raise --max-seconds or --max-photons and run again: the cached reference is continued)")
    if summary["rendered_for"] is not None:
        out.append(f"the reference was rendered for another request ({describe_budget(summary['rendered_for'])}) "
                   f"and served from the cache; against this run's request ({describe_budget(summary['request'])}) "
                   f"it stops by: {stopped_by}")
    return out


def experiment_summary(scene: Scene, p: ApproxParams, seeds: list[int], reference: ReferenceResult,
                       frames: Sequence[Frame], exact: dict | None, headline: dict, decomposition: dict | None,
                       divergence: dict | None, clock: dict[str, float], keep: np.ndarray, timed: list[dict],
                       model: dict | None = None, fields: dict | None = None,
                       request: ReferenceSettings | None = None) -> ExperimentSummary:
    alive = {} if exact is None else {k: float(max(v)) for k, v in exact["alive"].items()}
    names = {k: "E_em" if k == "true_emission" else f"E_inf ({k} Fresnel)" for k in alive}
    warnings = [f"{names[k]} keeps {100 * v:.2f}% of the power alive after {cast(dict, exact)['exact_steps']} steps "
                f"(> {100 * ALIVE_BUDGET:.1f}%): the truncation term is understated" for k, v in alive.items()
                if v > ALIVE_BUDGET]
    reference_part = reference_summary(reference, request)
    warnings += reference_warnings(reference_part)
    if decomposition is not None and not decomposition["residual"]["within_noise"]:
        warnings.append(decomposition["residual"]["message"])
    if model is not None and not model["converged"]:
        missing = ", ".join(c for c, n in model["orders_needed"].items() if n is None)
        warnings.append(f"{model['max_scatter']} scattering orders are not enough for {missing}: the last order still "
                        f"changes the total by more than the noise floor (the model term is understated); render the "
                        f"reference with a larger max_scatter")
    if len(seeds) < MIN_SEEDS_FOR_INTERVAL:
        warnings.append(f"{len(seeds)} seed(s): no intervals (they need {MIN_SEEDS_FOR_INTERVAL})"
                        + ("" if len(seeds) >= 2 else "; the approximation's own noise is not estimated, not "
                           "subtracted") + f"; use --seeds {MIN_SEEDS_FOR_INTERVAL} or more")
    return {
        "kind": KIND, "schema": SCHEMAS["experiment"], "scene": scene.name, "scene_hash": scene.scene_hash(),
        "optical_depth": optical_depth(scene),
        "description": scene.description, "params": p.to_dict(), "seeds": len(seeds), "seed_values": seeds,
        "reference": reference_part,
        "exact": None if exact is None else {
            "steps": exact["exact_steps"], "subset_batches": exact["subset_batches"], "alive_after": alive,
            "small_splat_radius": exact["small_radius"], "kernels": exact["kernels"],
            "small_supersample": SMALL_SUPERSAMPLE, "subphotons": exact["subphotons"],
            "batches": int(len(exact["batches"]["approx"])), "images_key": exact["exact_key"],
            "images_reused": exact["exact_reused"]},
        "compared_pixels": int(keep.sum()),
        "images": headline,
        "decomposition": None if decomposition is None else {
            "rows": decomposition["rows"], "residual": decomposition["residual"], "options": decomposition["options"]},
        "model": model,
        "paths": divergence,
        "map_reads": map_reads(frames), "cost": (cost := frame_costs(frames, p)),
        "predicted_frame": predicted_frames(cost, p),
        "approx_timings_s": median_timings(timed), "timed_frames": len(timed),
        "timing_method": frames[0].timing_method,
        "experiment_seconds": clock, "gl": gl_info(shared_context()),
        "code_version": code_version(), "versions": library_versions(), "warnings": warnings,
        "scene_fields": dict(fields or {}),
    }
