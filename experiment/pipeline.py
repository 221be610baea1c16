"""One experiment: a scene, the approximation's parameters and a reference → both
renders, the exact replay and every metric (docs/concepts/measuring.md.

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
  (``metrics.image``, ``metrics.noise``), the single-scattering model's own error
  when the reference has higher scattering orders (``model``), and the caustic's error decomposed
  (``metrics.decomposition``) with E_k (the replay above, splatted by the
  approximation's splatter), E_∞ (``measurement.EXACT_STEPS`` steps, A's Fresnel and
  stochastic), E_∞,s (small kernel, ``exact_images.SMALL_SUPERSAMPLE``× pixels box-filtered).

:func:`run_experiment` computes, stage by stage, each stage in its own module
(``frames``, ``segments``, ``photons``, ``exact_images``, ``images``,
``decomposition``, ``summary``); ``measure_outputs.write_experiment`` writes the tables (Parquet
and CSV), ``decomposition.exr`` and ``summary.json`` (last).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from tqdm import tqdm

from volcaustics.approx import Renderer
from volcaustics.experiment.approx_frames import render_frames
from volcaustics.experiment.decomposition_rows import decompose, decomposition_rows
from volcaustics.experiment.exact_images import exact_images
from volcaustics.experiment.image_rows import image_rows, keep_mask
from volcaustics.experiment.measurement import GATE_IMAGE_METRICS, SCOPE_PARTS, MeasurementSettings
from volcaustics.experiment.model_rows import model_rows
from volcaustics.experiment.photons import photon_rows, replay
from volcaustics.experiment.point_checks import checked_settings
from volcaustics.experiment.point_summary import (
    experiment_summary,
    experiment_views,
    parameter_columns,
)
from volcaustics.experiment.segments import segment_rows
from volcaustics.experiment.sizing import REPORT_REFERENCE, sized
from volcaustics.experiment.summaries import ExperimentSummary
from volcaustics.experiment.timing import Clock
from volcaustics.infra.errors import InputError
from volcaustics.reference.oracle import Oracle
from volcaustics.reference.render import render_reference

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reference.cache import ReferenceResult
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes.model import Scene

STAGES = ("reference", "oracle", "approx", "segments", "photons", "exact_images", "metrics")


class ExperimentError(InputError):
    """The experiment cannot say anything about this scene (e.g. no caustic reaches the
    pixels it compares); the message names the scene and the reason."""


@dataclass
class Experiment:
    """What :func:`run_experiment` measured: tidy rows and what ``summary.json`` holds,
    the decomposition images (name → H×W×3 float32) for the EXR, and the images a
    report shows (``point_summary.VIEWS``)."""

    segments: list
    photons: list
    images: list
    summary: ExperimentSummary
    layers: dict = field(default_factory=dict)
    views: dict = field(default_factory=dict)


def run_experiment(scene: Scene, params: ApproxParams, *, seeds: int = 1,
                   reference_settings: ReferenceSettings | None = None, progress: bool = False,
                   renderer: Renderer | None = None, oracle: Oracle | None = None,
                   reference: ReferenceResult | None = None, fields: dict | None = None,
                   measurement: MeasurementSettings | None = None) -> Experiment:
    """Measure the approximation with ``params`` on ``scene`` against its reference.

    Parameters
    ----------
    scene : ``scenes.model.Scene``.
    params : ``approx.ApproxParams`` (width/height unset: the scene camera's).
    seeds : frames with seeds params.seed … params.seed + seeds − 1 (≥ 1; the
        approximation's own noise and the bootstrap intervals need ≥ 2).
    reference_settings : ``reference.settings.ReferenceSettings`` (default: the
        report's, ``experiment.sizing.REPORT_REFERENCE``), sized to the frames;
        rendered when not cached (``reference`` None). The request the summary judges the
        reference by (``reference.served.judged``: its target and caps; with ``reference``
        given and no settings, the request the entry was rendered for).
    renderer, oracle, reference : reused when given (a ``reference.render.ReferenceResult``
        at the frames' size).
    fields : the scene fields this scene changed (dotted path → value, ``scenes.fields``):
        a column each in every row, and the summary's ``scene_fields``.
    measurement : how the point is measured, ``experiment.measurement.MeasurementSettings``
        (None: the report's): the exact images' sub-photons, subset batches and steps, and
        the scope (``measurement.SCOPE_PARTS``): "full"; "gate", only what the gate's budgets
        read (the image metrics of ``measurement.GATE_IMAGE_METRICS`` and the segments): the
        exact images, the caustic's decomposition and the model term are skipped (the
        summary's ``exact``, ``decomposition`` and ``model`` are then None); or
        "decomposition", only what the caustic's closure reads (those image metrics, the
        exact images and the decomposition): no timed frames (the summary's
        ``approx_timings_s`` empty, ``timed_frames`` 0), no segment or photon rows (its
        ``paths`` None) and no model term.
    """
    p, seed_list = checked_settings(scene, params, seeds)
    measurement = measurement or MeasurementSettings()
    parts = SCOPE_PARTS[measurement.scope]
    clock = Clock()
    bar = tqdm(total=len(STAGES), desc="measure", unit="stage", disable=not progress, leave=False)
    # the request the summary judges the reference by (None: the one the given entry was rendered for)
    request = None if reference is not None and reference_settings is None else \
        sized(reference_settings or REPORT_REFERENCE, scene, p)
    with clock.stage("reference"):
        if reference is None:
            reference = render_reference(scene, sized(reference_settings or REPORT_REFERENCE, scene, p),
                                         progress=progress)
    bar.update()
    own_renderer = renderer is None
    renderer = renderer or Renderer(scene)
    columns = parameter_columns(scene, p, seed_list, reference.key, fields)
    try:
        with clock.stage("oracle"):
            oracle = oracle or Oracle(scene)
        with clock.stage("approx"):
            frames, timed = render_frames(renderer, scene, p, seed_list, warm_up=own_renderer,
                                          timing="timings" in parts)
        bar.update(2)
        segments, photons, divergence = _frame_tables(scene, p, frames, seed_list, oracle, columns, parts, clock)
        bar.update(2)
        exact = None
        if "exact" in parts:
            with clock.stage("exact_images"):
                exact = exact_images(scene, p, frames, seed_list, renderer, oracle, measurement)
        bar.update()
    finally:
        if own_renderer:
            renderer.release()
    with clock.stage("metrics"):
        maps: dict
        keep, maps = keep_mask(reference, frames), {}
        images, headline = image_rows(frames, reference, keep, columns, maps,
                                      metrics=None if "metrics" in parts else GATE_IMAGE_METRICS)
        decomposition = None if exact is None else _decomposed(scene, exact, reference, keep)
        images += [] if decomposition is None else decomposition_rows(decomposition, columns)
        model, model_summary = model_rows(frames, reference, keep, columns) if "model" in parts else ([], None)
        images += model
    bar.update()
    bar.close()
    clock.seconds["total"] = clock.total()
    summary = experiment_summary(scene, p, seed_list, reference, frames, exact, headline, decomposition, divergence,
                                 clock.seconds, keep, timed, model_summary, fields, request=request)
    layers = {}
    if decomposition is not None:
        layers = {name: np.asarray(img, np.float32) for name, img in decomposition["images"].items()}
        layers.update({f"term.{name}": np.asarray(img, np.float32) for name, img in decomposition["terms"].items()})
    return Experiment(segments=segments, photons=photons, images=images, summary=summary, layers=layers,
                      views=experiment_views(frames, reference, keep, layers, maps))


def _frame_tables(scene, p, frames, seeds, oracle, columns, parts, clock) -> tuple[list, list, dict | None]:
    """The segments' rows, the photon paths' rows and where the paths first diverge, each
    where the scope's ``parts`` ask for it (else none), timed as stages of ``clock``."""
    segments, photons, divergence = [], [], None
    if "segments" in parts:
        with clock.stage("segments"):
            segments = segment_rows(scene, p, frames, oracle, columns)
    if "photons" in parts:
        with clock.stage("photons"):
            replays = [replay(scene, p, f, s, oracle) for f, s in zip(frames, seeds)]
            photons, divergence = photon_rows(frames, replays, columns)
    return segments, photons, divergence


def _decomposed(scene, exact, reference, keep) -> dict:
    try:
        return decompose(exact, reference, keep)
    except ValueError as exc:
        raise ExperimentError(f"{scene.name}: cannot decompose the caustic's error: {exc}") from None
