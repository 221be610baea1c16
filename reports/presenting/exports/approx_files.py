"""`volcaustics approx`: render one scene with the paper's method and write
OUT.exr (all layers), OUT.png (tonemapped combined), OUT.records.npz (segment
records) and OUT.json (timings, parameters, scene hash), written as one unit
(``infra.storage.atomic_set``)."""

from __future__ import annotations

import json
import os
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.approx import render
from volcaustics.approx.frame_checks import check_finite_frame
from volcaustics.infra.imageio import write_exr, write_png
from volcaustics.infra.storage import atomic_set
from volcaustics.reports.presenting.exports.output_paths import render_outputs

if TYPE_CHECKING:
    from volcaustics.approx.frame import Frame
    from volcaustics.approx.params import ApproxParams
    from volcaustics.scenes.model import Scene


def output_paths(out: str) -> dict:
    return render_outputs(out, {"png": ".png", "records": ".records.npz", "json": ".json"})


def subsample_records(records: list, max_per_step: int) -> tuple[np.ndarray, int]:
    """All steps' records in one array, keeping at most ``max_per_step`` per step by a
    fixed stride over photon order (deterministic); returns (records, stride)."""
    if not records or max_per_step == 0:
        return np.zeros(0), 0
    longest = max(len(r) for r in records)
    stride = 1 if max_per_step < 0 or longest <= max_per_step else int(np.ceil(longest / max_per_step))
    return np.concatenate([r[::stride] for r in records]), stride


def run_approx(scene: Scene, params: ApproxParams, out: str, *, records_max: int = 200_000) -> tuple[Frame, dict]:
    """Render and write the outputs; returns the frame and the paths written (name → absolute path)."""
    frame = render(scene, params, keep_records=records_max != 0)
    paths = output_paths(out)
    check_finite_frame(frame.images, params, paths["exr"])  # NonFiniteFrame: exit 2, nothing written
    metadata = {"volcaustics_scene": scene.name, "volcaustics_scene_hash": scene.scene_hash(),
                "volcaustics_renderer": "approx", "volcaustics_params": json.dumps(frame.params, sort_keys=True)}
    recs, stride = subsample_records(frame.records, records_max)
    outputs = {k: os.path.abspath(v) for k, v in paths.items()}
    summary = {
        "scene": scene.name, "scene_hash": scene.scene_hash(), "params": frame.params,
        "timings_s": frame.timings, "timing_method": frame.timing_method, "gl": frame.gl,
        "photons_emitted": frame.photons_emitted, "records_stride": stride,
        "outputs": outputs,
    }
    # one unit: an interrupted run leaves the last complete set, never files of two runs
    with atomic_set([paths["exr"], paths["png"], paths["records"], paths["json"]]) as (exr, png, records, manifest):
        write_exr(exr, frame.images, metadata)
        write_png(png, frame.images["combined"])
        with open(records, "wb") as fh:
            np.savez(fh, records=recs, stride=np.int64(stride))
        with open(manifest, "w") as fh:
            fh.write(json.dumps(summary, indent=2, default=float))
    return frame, outputs
