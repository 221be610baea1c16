"""Segment records from the GPU tracer's raw layout.

The layouts and codes are ``scenes.formats``: per step the tracer writes one
``RAW_RECORD_DTYPE`` row (std430 ``Record``) per photon slot; :func:`records_from_raw`
turns them into ``RECORD_DTYPE`` rows, the format the exact photon tracer
also writes and metrics compare.
"""

from __future__ import annotations

import numpy as np

from volcaustics.scenes.formats import RECORD_DTYPE, STATUS_COLLIDED, STATUS_DEAD, STATUS_SURFACE


def records_from_raw(raw: np.ndarray, step: int, *, active_only: bool = True,
                     differentials: np.ndarray | None = None) -> np.ndarray:
    """Convert one step's raw GPU records (N rows of RAW_RECORD_DTYPE) to RECORD_DTYPE
    (photons not dead at this step, or every slot when ``active_only`` is false);
    ``differentials``: per slot, what the step's kernels were made of
    (``PhotonTracer.kernel_source``, DIFFERENTIAL_DTYPE: splat = adaptive the
    footprint after the step, beam_width = differential the footprint at the segment's
    start and its rate), else 0."""
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
    out["map_reads"] = r["power_start"][:, 3]
    out["footprint"] = 0.0 if differentials is None else differentials["footprint"][index]
    out["footprint_rate"] = 0.0 if differentials is None else differentials["rate"][index]
    return out


def emission_records(photons: np.ndarray) -> np.ndarray:
    """The step-1 records' emission state of photons after emission (PHOTON_DTYPE,
    one per slot): what trace.comp.glsl copies from a live photon (status surface or
    collided) into its record before the step: photon (slot), start (pos.xyz),
    direction (dir.xyz), inside (pos.w), power_start (power.rgb); step 1, the other
    fields 0."""
    status = np.floor(photons["dir"][:, 3] + np.float32(0.5)).astype(np.int64)  # int(w + 0.5) of the shader
    index = np.nonzero((status == STATUS_SURFACE) | (status == STATUS_COLLIDED))[0]
    live = photons[index]
    out = np.zeros(len(live), dtype=RECORD_DTYPE)
    out["photon"], out["step"] = index, 1
    out["start"] = live["pos"][:, :3]
    out["direction"] = live["dir"][:, :3]
    out["inside"] = live["pos"][:, 3]
    out["power_start"] = live["power"][:, :3]
    return out
