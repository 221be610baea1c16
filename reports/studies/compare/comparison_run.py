"""Another renderer's frames of a scene against the reference: the same image metrics,
noise debiasing and error maps the approximation gets (``experiment.image_rows``:
one code path, so ``compare`` on the approximation's own EXRs gives ``measure``'s
numbers). The segment and photon metrics need the approximation's records and stay
``measure``'s.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.experiment.image_rows import image_rows, keep_mask
from volcaustics.experiment.point_checks import check_medium
from volcaustics.experiment.point_summary import reference_summary, reference_warnings
from volcaustics.experiment.sizing import at_size
from volcaustics.experiment.summaries import SCHEMAS
from volcaustics.experiment.timing import Clock
from volcaustics.experiment.versions import code_version, library_versions
from volcaustics.metrics.noise import MIN_SEEDS_FOR_INTERVAL
from volcaustics.reports.measuring import runner
from volcaustics.reports.studies.compare.comparison_inputs import CompareError, read_images

if TYPE_CHECKING:
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes.model import Scene

KIND = "compare"  # summary.json "kind" of a compare output folder
VIEWS = {"renderer.<component>": "the renderer's images, mean over the files (H×W×3)",
         "reference.<component>": "the reference's mean (H×W×3)",
         "map.per_pixel_relative_mse.<component>": "per-pixel relative MSE of the first file (H×W, NaN: not "
                                                   "compared)",
         "map.hdr_flip.<component>": "HDR-FLIP error of the first file (H×W in [0, 1], NaN: not compared)",
         "compared": "1 where pixels are compared, else 0 (H×W)"}


@dataclass
class Comparison:
    """What :func:`run_compare` measured: the image rows (``images.parquet``), what
    ``summary.json`` holds and the images (:data:`VIEWS`)."""

    images: list
    summary: dict
    views: dict = field(default_factory=dict)


def run_compare(scene: Scene, paths: Iterable[str], *, name: str, reference_settings: ReferenceSettings,
                policy: str = "continue", progress: bool = False) -> Comparison:
    """Measure the images ``paths`` (one per seed) of ``scene`` by the renderer ``name``
    against the reference at their size (``reference_settings``, unsized: the runner's
    reference under ``policy``). CompareError for images that cannot be judged, before
    the reference renders."""
    check_medium(scene)  # a medium without a caustic to compare: before the files are read
    clock = Clock()
    with clock.stage("read"):
        inputs = read_images(list(paths), scene)
    request = at_size(reference_settings, inputs.width, inputs.height)
    with clock.stage("reference"):
        reference = runner.reference_for(scene, request, policy, progress=progress)
    with clock.stage("metrics"):
        keep = keep_mask(reference, inputs.frames)
        if not keep.any():
            raise CompareError(f"{scene.name}: every pixel sees glass (the reference's and the files' "
                               f"mask_specular): nothing to compare")
        columns = {"scene": scene.name, "scene_hash": scene.scene_hash(), "renderer": name,
                   "seeds": len(inputs.frames), "width": inputs.width, "height": inputs.height,
                   "reference_key": reference.key, "code_version": code_version()}
        maps: dict = {}
        rows, headline = image_rows(inputs.frames, reference, keep, columns, maps, components=inputs.components)
    clock.seconds["total"] = clock.total()
    judged = reference_summary(reference, request)  # against this run's target and caps
    summary = {
        "kind": KIND, "schema": SCHEMAS["comparison"], "renderer": name, "scene": scene.name,
        "scene_hash": scene.scene_hash(),
        "description": scene.description, "width": inputs.width, "height": inputs.height,
        "seeds": len(inputs.frames), "inputs": inputs.files, "components": list(inputs.components),
        "mask": inputs.mask, "reference": judged, "compared_pixels": int(keep.sum()),
        "images": headline, "seconds": clock.seconds, "code_version": code_version(),
        "versions": library_versions(),
        "warnings": inputs.warnings + reference_warnings(judged) + _seed_warnings(len(inputs.frames)),
    }
    return Comparison(images=rows, summary=summary, views=_views(inputs, reference, keep, maps))


def _seed_warnings(seeds: int) -> list:
    if seeds >= MIN_SEEDS_FOR_INTERVAL:
        return []
    return [f"{seeds} file(s): no intervals (they need {MIN_SEEDS_FOR_INTERVAL} seeds)"
            + ("" if seeds >= 2 else "; the renderer's own noise is not estimated, not subtracted")
            + f"; give {MIN_SEEDS_FOR_INTERVAL} or more images rendered with different seeds"]


def _views(inputs, reference, keep, maps) -> dict:
    out = {}
    for component in inputs.components:
        out[f"renderer.{component}"] = np.mean([f.images[component] for f in inputs.frames], axis=0)
        out[f"reference.{component}"] = reference.mean[component]
    for (metric, component), image in maps.items():
        out[f"map.{metric}.{component}"] = image
    out["compared"] = keep
    return {name: np.asarray(image, np.float32) for name, image in out.items()}
