"""Temporal reuse (``temporal`` = ema): the caustic and fog of consecutive frames, each
rendered with a new seed, accumulated by an exponential moving average
H_t = w·A_t + (1 − w)·H_{t−1} (w = ``temporal_weight``), the history kept per pixel only
where the scene there did not change:

* **rejected** where the G-buffer's eye distance changed by more than
  DISTANCE_TOLERANCE (relative) or its normal turned by more than NORMAL_COS (an object
  or the camera moved: the pixel sees another surface);
* **reset everywhere** on a cut: the light moved by more than CUT_DEGREES as seen from
  the medium's centre or turned by more than that (:func:`light_cut`);
* **clipped** to the current frame's neighbourhood, mean ± CLIP_SIGMAS standard
  deviations over a CLIP_WINDOW² window (variance clipping, Salvi 2016, as temporal
  anti-aliasing does; cf. SVGF, Schied et al. 2017): a caustic that moves with a
  slowly moving light leaves no trail longer than the clipping allows.

A young history (n frames since a reset) takes the weight max(w, 1/(n + 1)), its plain
mean, so that it settles in a few frames (as SVGF does). With w the steady-state noise
variance drops to w/(2 − w) of one frame's; the price is
lag, which ``metrics.temporal.trailing_lag`` measures against the reference sequence.
Static camera assumed for reprojection: a camera that moves rejects by the G-buffer
test (no motion vectors are traced).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import uniform_filter

if TYPE_CHECKING:
    from volcaustics.scenes.model import SpotLight

DISTANCE_TOLERANCE = 0.02
NORMAL_COS = 0.95
CUT_DEGREES = 10.0
CLIP_WINDOW = 5
CLIP_SIGMAS = 1.0
REUSED = ("caustic", "fog")  # the noisy layers; direct is noise-free and follows the frame


def light_cut(before: SpotLight, after: SpotLight, centre: np.ndarray) -> bool:
    """Whether the spot light moved or turned by more than CUT_DEGREES between two
    frames (``centre``: the medium's centre, from which its position's move is seen)."""
    def angle(u, v):
        u, v = np.asarray(u, float), np.asarray(v, float)
        c = np.dot(u, v) / max(np.linalg.norm(u) * np.linalg.norm(v), 1e-12)
        return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    moved = angle(np.asarray(before.position) - centre, np.asarray(after.position) - centre)
    return max(moved, angle(before.direction, after.direction)) > CUT_DEGREES


def history_valid(distance_before: np.ndarray, distance: np.ndarray, normal_before: np.ndarray,
                  normal: np.ndarray) -> np.ndarray:
    """H×W bool: where the pixel sees the same surface as the frame before."""
    close = np.abs(distance - distance_before) <= DISTANCE_TOLERANCE * np.maximum(distance, 1e-6)
    facing = np.sum(normal * normal_before, axis=-1) >= NORMAL_COS
    empty = (distance <= 0) & (distance_before <= 0)  # nothing hit in either: the medium only
    return (close & facing) | empty


def _clip(history: np.ndarray, current: np.ndarray) -> np.ndarray:
    size = (CLIP_WINDOW, CLIP_WINDOW, 1)
    mean = uniform_filter(current, size=size, mode="nearest")
    sigma = np.sqrt(np.maximum(uniform_filter(current * current, size=size, mode="nearest") - mean * mean, 0.0))
    return np.clip(history, mean - CLIP_SIGMAS * sigma, mean + CLIP_SIGMAS * sigma)


def ema(frames: np.ndarray, distance: np.ndarray, normal: np.ndarray, cuts: Sequence[bool], weight: float,
        *, clip: bool = True, reject: bool = True) -> np.ndarray:
    """T×H×W×C: the moving average of ``frames`` (T×H×W×C, a new seed each) with the
    history rejected, reset and clipped as the module docstring says; ``distance``
    T×H×W and ``normal`` T×H×W×3 are each frame's G-buffer, ``cuts`` (T bools) the
    frames that start afresh. ``clip``/``reject`` False: a test's plain average."""
    frames = np.asarray(frames, np.float64)
    out = np.empty_like(frames)
    out[0] = frames[0]
    length = np.ones(frames.shape[1:3] + (1,))  # frames in each pixel's history
    for t in range(1, len(frames)):
        if reject and cuts[t]:
            out[t], length[:] = frames[t], 1.0
            continue
        history = _clip(out[t - 1], frames[t]) if clip else out[t - 1]
        w = np.maximum(weight, 1.0 / (length + 1.0))  # a young history: its plain mean (SVGF's rule)
        blended = w * frames[t] + (1.0 - w) * history
        length += 1.0
        if reject:
            keep = history_valid(distance[t - 1], distance[t], normal[t - 1], normal[t])[..., None]
            blended = np.where(keep, blended, frames[t])
            length = np.where(keep, length, 1.0)
        out[t] = blended
    return out.astype(np.float32)
