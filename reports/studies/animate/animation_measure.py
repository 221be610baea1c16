"""An animation measured (``volcaustics animate``): every frame of the approximation and the
reference through one Renderer and the cache (``run``), temporal reuse beside, the tables,
the summary (its ``schema``: ``experiment.summaries.SCHEMAS``) and the media, stored as one
sealed set in the result store under the animation's key and copied to ``-o DIR``."""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING

from volcaustics.experiment.sizing import sized
from volcaustics.experiment.summaries import SCHEMAS
from volcaustics.experiment.versions import code_version
from volcaustics.reports.measuring.results.sealed_sets import copy_set
from volcaustics.reports.measuring.results.store import point_key
from volcaustics.reports.measuring.runner import measure_set
from volcaustics.reports.studies.animate.animation_frames import render_animation
from volcaustics.reports.studies.animate.animation_metrics import frame_rows, summarize, temporal_rows
from volcaustics.reports.studies.animate.animation_read import KIND
from volcaustics.reports.studies.animate.animation_settings import CVVDP_SKIPPED
from volcaustics.reports.studies.animate.animation_write import write_animation
from volcaustics.reports.studies.animate.temporal import add_ema

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.reports.measuring.results.store import Store
    from volcaustics.scenes.model import Scene


ANIMATIONS = "animations"  # <store>/animations/<key>/: one sealed set per animation (results.sealed_sets)


def animation_key(scene: Scene, params: ApproxParams, *, frames: list, modes: tuple, chains: int,
                  reference_settings: ReferenceSettings) -> str:
    """The key of an animation in the result store: everything that decides it (the scene's
    content and name, the parameters, frames, seed modes, chains, the references' settings
    at the frames' size) and the code version."""
    sized_settings = sized(reference_settings, scene, params)
    return point_key({"kind": KIND, "scene_hash": scene.scene_hash(), "scene": scene.name,
                      "params": params.to_dict(), "frames": list(frames), "modes": list(modes), "chains": chains,
                      "reference": sized_settings.to_dict(), "code_version": code_version()})


def run_animate(scene: Scene, params: ApproxParams, *, frames: list, modes: tuple, chains: int,
                reference_settings: ReferenceSettings, out_dir: str, store: Store,
                progress: bool = True) -> tuple:
    """Measure ``scene``'s animation at ``frames`` in each seed mode of ``modes`` (with
    ``temporal = ema``, also per-frame beside it) over ``chains`` chains through the runner
    into the result ``store`` (``runner.measure_set``: a sealed set under its key, read
    back when stored, never measured twice), then copy it into ``out_dir``; returns
    (summary, paths written, measured)."""
    modes = modes + (("per-frame",) if params.temporal == "ema" and "per-frame" not in modes else ())
    key = animation_key(scene, params, frames=frames, modes=modes, chains=chains,
                        reference_settings=reference_settings)
    stored = measure_set(store, ANIMATIONS, key, KIND, lambda into: _measure(
        scene, params, frames=frames, modes=modes, chains=chains, reference_settings=reference_settings,
        work_dir=out_dir, into=into, progress=progress))
    return stored.summary, copy_set(stored.folder, stored.summary, out_dir), stored.measured


def _measure(scene: Scene, params: ApproxParams, *, frames: list, modes: tuple, chains: int,
             reference_settings: ReferenceSettings, work_dir: str, into: str, progress: bool) -> dict:
    """Render the frames (resumable in ``work_dir``'s ``.animate``), measure them and write
    the set's files into ``into``; returns its summary."""
    t0 = time.perf_counter()
    run_ = render_animation(scene, params, frames=frames, modes=modes, chains=chains,
                            reference_settings=reference_settings, out_dir=work_dir, progress=progress)
    add_ema(run_, params)  # temporal = ema: a seed mode of its own, beside per-frame
    frames_table, temporal = frame_rows(run_), temporal_rows(run_)
    summary = {"kind": KIND, "schema": SCHEMAS["animation"], "scene": scene.name, "scene_hash": scene.scene_hash(),
               "animation": scene.animation.canonical_dict(),
               "frames": frames, "seed_modes": list(run_.modes), "chains": chains, "params": params.to_dict(),
               "reference": {**dataclasses.asdict(reference_settings), "width": params.width, "height": params.height,
                             "keys": [r.key for r in run_.references]},
               "metrics": summarize(run_, frames_table, temporal),
               "seconds": {"approx_frame_median": _median(run_.approx_seconds),
                           "reference_frame_median": _median(run_.reference_seconds),
                           "references_cached": sum(run_.reference_cached), "frames_resumed": run_.resumed,
                           "total": time.perf_counter() - t0},
               "perceptual_video_metric": {"name": "ColorVideoVDP", "measured": False, "reason": CVVDP_SKIPPED},
               "gl": run_.gl, "code_version": code_version()}
    return write_animation(run_, frames_table, temporal, summary, into)


def _median(values) -> float:
    ordered = sorted(values)
    return ordered[len(ordered) // 2] if ordered else float("nan")


