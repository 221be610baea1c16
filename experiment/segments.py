"""Segments: every searched segment asked of the exact oracle on the same interval and
classified (``metrics.intersection``), tabulated per grouping."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from volcaustics.approx.light import LightFrustum
from volcaustics.metrics.intersection import SELF_REHIT, classify_segments, intersection_table
from volcaustics.scenes.bounds import medium_bounds

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Frame
    from volcaustics.reference.oracle import Oracle
    from volcaustics.scenes.model import Scene

SEGMENT_GROUPINGS = (("step", "map", "inside"), ("step", "inside"), ("step",), ())
BEYOND_SKIP = 10.0           # a self re-hit's re-query starts this many oracle epsilons past the surface


def start_normals(records: list) -> list:
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


def segment_rows(scene: Scene, p: ApproxParams, frames: Sequence[Frame], oracle: Oracle, columns: dict) -> list:
    records = np.concatenate([r for f in frames for r in f.records])
    start_normal = np.concatenate([n for f in frames for n in start_normals(f.records)])
    exact = oracle.first_hits(records["start"], records["direction"], records["search_length"])
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    options: dict[str, Any] = {"texel_angle": 2.0 * frustum.tan_half / p.light_res,
               "light_position": np.asarray(scene.light.position), "start_normal": start_normal}
    first = classify_segments(records, exact, **options)
    beyond_hits = beyond(records, exact, first["cls"] == SELF_REHIT, oracle)
    classes = classify_segments(records, exact, exact_beyond=beyond_hits, **options)
    rows = []
    for group_by in SEGMENT_GROUPINGS:
        for row in intersection_table(records, classes, group_by=group_by, parameters=columns):
            rows.append({"grouping": ",".join(group_by) or "all", **row})
    return rows


def beyond(records: np.ndarray, exact: dict, self_rehit: np.ndarray, oracle: Oracle) -> dict:
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
