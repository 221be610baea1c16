"""The approximation's frames of an experiment: one per seed with its segment records,
and the pass times of frames rendered as a user would (no records)."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from volcaustics.approx.frame_checks import check_finite_frame

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Frame, Renderer
    from volcaustics.scenes.model import Scene

TIMED_FRAMES = 3             # frames without records timed per experiment (the median one is reported)


def render_frames(renderer: Renderer, scene: Scene, p: ApproxParams, seeds: list[int], *,
                  warm_up: bool, timing: bool = True) -> tuple[list[Frame], list[dict]]:
    """One frame per seed, with records, and the pass times of TIMED_FRAMES frames
    rendered as a user would (no records: reading them back is the harness's cost, not
    the method's). A fresh renderer compiles its shaders in its first frame, so it
    renders one frame first that is not timed. ``timing`` False: the record frames alone
    (no pass times, no warm-up)."""
    if warm_up and timing:
        renderer.render(scene, dataclasses.replace(p, seed=seeds[0]), keep_records=False)
    frames = [renderer.render(scene, dataclasses.replace(p, seed=s), keep_records=True) for s in seeds]
    for seed, frame in zip(seeds, frames):  # NonFiniteFrame: exit 2 before any metric reads NaN
        check_finite_frame(frame.images, p, f"{scene.name}: the approximation's frame of seed {seed}")
    timed = [renderer.render(scene, dataclasses.replace(p, seed=seeds[i % len(seeds)]), keep_records=False).timings
             for i in range(TIMED_FRAMES if timing else 0)]
    return frames, timed


def median_timings(timed: list) -> dict:
    """The pass times of the timed frame with the median frame time (one frame's, so
    its passes add up to at most its frame time); none without timed frames."""
    if not timed:
        return {}
    order = sorted(range(len(timed)), key=lambda i: timed[i]["frame_wall"])
    return {name: float(v) for name, v in timed[order[len(order) // 2]].items()}
