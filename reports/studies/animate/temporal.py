"""An animation's temporally reused sequence (``temporal`` = ema): the chains of the
``per-frame`` seed mode (a new seed every frame) filtered by ``approx.temporal.ema``
into a seed mode of their own, EMA_MODE, measured like the others (per-frame error,
flicker, lag), so that the page and the tables show the two side by side."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from volcaustics.approx.temporal import REUSED, ema, light_cut
from volcaustics.scenes.bounds import medium_bounds

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reports.studies.animate.animation_frames import AnimationFrames

EMA_MODE = "per-frame+ema"
SOURCE_MODE = "per-frame"


def cuts(run: AnimationFrames) -> list:
    """Per rendered frame, whether it starts afresh: the light jumped since the last one."""
    lo, hi = medium_bounds(run.scene)
    centre = (np.asarray(lo, float) + np.asarray(hi, float)) / 2.0
    scenes = [run.scene.animation.scene_at(run.scene, t) for t in run.frames]
    return [False] + [light_cut(a.light, b.light, centre) for a, b in zip(scenes, scenes[1:])]


def add_ema(run: AnimationFrames, params: ApproxParams) -> None:
    """Add EMA_MODE to ``run`` (``reports.studies.animate.animation_frames.AnimationFrames``) when
    ``params.temporal`` is ema; the per-frame seed mode must have been rendered."""
    if params.temporal != "ema" or EMA_MODE in run.approx:
        return
    source = run.approx[SOURCE_MODE]
    jumps = cuts(run)
    out = {layer: np.array(images, copy=True) for layer, images in source.items()}
    for chain in range(run.chains):
        for layer in REUSED:
            out[layer][chain] = ema(source[layer][chain], run.guides["distance"], run.guides["normal"], jumps,
                                    params.temporal_weight)
    out["combined"] = out["caustic"] + out["fog"] + out["direct"]
    run.approx[EMA_MODE] = out
    run.modes = (*run.modes, EMA_MODE)
