"""Photon and segment-record layouts shared with ``common/photon.glsl``.

Per step the tracer writes one :data:`RECORD_DTYPE` row per photon slot; the
numpy view exposes what the exact oracle needs: segment start, direction,
max length, estimated t, hit flag, map (layer) index, estimated normal, status.
"""

from __future__ import annotations

import numpy as np

STATUS_DEAD, STATUS_SURFACE, STATUS_COLLIDED, STATUS_LEFT_SCENE, STATUS_LOST = range(5)
STATUS_NAMES = {STATUS_DEAD: "dead", STATUS_SURFACE: "surface", STATUS_COLLIDED: "collided",
                STATUS_LEFT_SCENE: "left_scene", STATUS_LOST: "lost"}
FLAG_LEFT_FRUSTUM, FLAG_REFLECTED, FLAG_TIR = 1, 2, 4

PHOTON_DTYPE = np.dtype([("pos", "<f4", 4), ("dir", "<f4", 4), ("power", "<f4", 4)])
SPLAT_DTYPE = np.dtype([("center_status", "<f4", 4), ("dir", "<f4", 4), ("power", "<f4", 4)])
RAW_RECORD_DTYPE = np.dtype([("start_maxlen", "<f4", 4), ("dir_t", "<f4", 4), ("normal_map", "<f4", 4),
                             ("end_status", "<f4", 4), ("power_inside", "<f4", 4), ("extra", "<f4", 4),
                             ("power_start", "<f4", 4)])

RECORD_DTYPE = np.dtype([
    ("photon", "<u4"),        # photon index = emission texel (row * photon_res + column)
    ("step", "<u2"),          # interaction step, 1..steps
    ("start", "<f4", 3),      # segment start (world, m)
    ("direction", "<f4", 3),  # unit direction
    ("max_length", "<f4"),    # sampled free-flight distance (medium) or scene span (inside glass)
    ("search_length", "<f4"), # length actually searched (max_length clipped to the scene box)
    ("start_offset", "<f4"),  # the search began this far from the start (m; common/start_offset.glsl)
    ("t", "<f4"),             # estimated first-hit distance, nan if no hit
    ("hit", "?"),
    ("map", "<i2"),           # light map of the hit: 2 * layer + (0 front, 1 back); -1 if no hit
    ("normal", "<f4", 3),     # estimated normal at the hit (nan if no hit)
    ("material", "<i2"),      # specular object hit (-1 none)
    ("inside", "<i2"),        # specular object the segment runs inside (-1: medium)
    ("end", "<f4", 3),        # where the step ended
    ("power_start", "<f4", 3),  # power at the segment start (W, RGB)
    ("power", "<f4", 3),      # power after the step (W, RGB)
    ("status", "<u1"),        # STATUS_* after the step
    ("flags", "<u1"),         # FLAG_* bits
])


def records_from_raw(raw: np.ndarray, step: int, *, active_only: bool = True) -> np.ndarray:
    """Convert one step's raw GPU records (N rows of RAW_RECORD_DTYPE) to RECORD_DTYPE."""
    status = raw["end_status"][:, 3].astype(np.int64)
    index = np.nonzero(status != STATUS_DEAD)[0] if active_only else np.arange(len(raw))
    r = raw[index]
    out = np.empty(len(r), dtype=RECORD_DTYPE)
    out["photon"] = index
    out["step"] = step
    out["start"] = r["start_maxlen"][:, :3]
    out["direction"] = r["dir_t"][:, :3]
    out["max_length"] = r["start_maxlen"][:, 3]
    out["search_length"] = r["extra"][:, 2]
    out["start_offset"] = r["extra"][:, 3]
    hit = r["dir_t"][:, 3] >= 0
    out["hit"] = hit
    out["t"] = np.where(hit, r["dir_t"][:, 3], np.nan)
    out["map"] = np.where(hit, r["normal_map"][:, 3], -1)
    out["normal"] = np.where(hit[:, None], r["normal_map"][:, :3], np.nan)
    out["material"] = r["extra"][:, 1]
    out["inside"] = r["power_inside"][:, 3]
    out["end"] = r["end_status"][:, :3]
    out["power_start"] = r["power_start"][:, :3]
    out["power"] = r["power_inside"][:, :3]
    out["status"] = r["end_status"][:, 3]
    out["flags"] = r["extra"][:, 0]
    return out
