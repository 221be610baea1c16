"""Photons: where the power goes, step by step, and where a path leaves its exact replay.

Both tracers write per-step segment records in one format (``scenes.formats.
RECORD_DTYPE``): the approximation's GPU tracer and the exact photon tracer that
replays the same photons with the same random numbers. From them (docs/concepts/measuring.md
"Measuring the error" → Photons):

* :func:`power_budget`: per step, the power (mean over RGB) whose step ended at a
  surface (the path goes on), in a medium collision (splatted), lost inside glass,
  leaving the scene — and after the last step what is still alive — as shares of
  the power entering step 1;
* :func:`path_divergence`: per photon, the first step where the approximation's path
  leaves the exact one and why (another fate, or the same fate at another place), the
  endpoint distance and the power drift at that step.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from volcaustics.scenes.formats import STATUS_COLLIDED, STATUS_LEFT_SCENE, STATUS_LOST, STATUS_NAMES, STATUS_SURFACE

FATES = {STATUS_SURFACE: "surface", STATUS_COLLIDED: "collided", STATUS_LOST: "lost", STATUS_LEFT_SCENE: "left_scene"}
CAUSE_FATE, CAUSE_PLACE = "fate", "place"
_FIELDS = ("photon", "step", "status", "power_start", "power", "end")


def _check(records) -> list:
    if isinstance(records, np.ndarray):
        records = [records]
    records = list(records)
    if not records:
        raise ValueError("records: expected one array of segment records per step, got none")
    for k, r in enumerate(records):
        missing = [f for f in _FIELDS if r.dtype.names is None or f not in r.dtype.names]
        if missing:
            raise ValueError(f"records[{k}]: missing fields {missing} (expected scenes.formats.RECORD_DTYPE)")
    return records


def _power(x) -> np.ndarray:
    """Mean over RGB per photon (N, or N×3 → N); a step no photon reached gives N = 0."""
    x = np.asarray(x, np.float64)
    return x.reshape(len(x), int(np.prod(x.shape[1:]))).mean(axis=1)


def power_budget(records: np.ndarray | Iterable[np.ndarray], *, tracer: str = "approx") -> list:
    """Power by fate per step, as tidy rows.

    Parameters
    ----------
    records : list of RECORD_DTYPE arrays, one per step (step 1 first), the photons
        alive at that step (as ``approx.Frame.records`` or
        ``reference.oracle.exact_photon_records`` give them).
    tracer : a label for the rows ("approx", "exact").

    Returns
    -------
    list of dict, one per step: ``step``, ``tracer``, ``share_<fate>`` for every fate
    of FATES (power whose step ended so, over the power entering step 1, mean over
    RGB), ``share_entering`` (power entering the step), and a last row with step
    ``"after"`` holding ``share_alive`` (power still on its way after the last step).
    The shares of all steps' collided, lost and left_scene plus ``share_alive`` sum to 1
    minus what the medium and the glass absorbed on the way. When no power enters step 1
    (a dark light, a spot that misses the glass) every share is NaN: undefined, not an error.
    """
    records = _check(records)
    total = float(_power(records[0]["power_start"]).sum())
    if not total > 0:  # no photon carries power (a dark light, a spot that misses the glass): undefined
        total = float("nan")
    rows: list[dict] = []
    for r in records:
        step = int(r["step"][0]) if len(r) else len(rows) + 1
        row = {"tracer": tracer, "step": step, "share_entering": float(_power(r["power_start"]).sum()) / total}
        power = _power(r["power"])
        for status, fate in FATES.items():
            row[f"share_{fate}"] = float(power[r["status"] == status].sum()) / total
        rows.append(row)
    last = records[-1]
    alive = _power(last["power"])[(last["status"] == STATUS_SURFACE) | (last["status"] == STATUS_COLLIDED)]
    rows.append({"tracer": tracer, "step": "after", "share_alive": float(alive.sum()) / total})
    return rows


def path_divergence(approx: np.ndarray | Iterable[np.ndarray], exact: np.ndarray | Iterable[np.ndarray], *,
                    place_tolerance: float = 1e-3) -> dict:
    """Per photon of step 1, the first step where the approximation leaves its exact
    replay.

    Parameters
    ----------
    approx, exact : lists of RECORD_DTYPE arrays, one per step, same photons (the
        exact replay starts from the approximation's step-1 records).
    place_tolerance : metres; a step with the same fate whose end points lie farther
        apart diverges by place.

    Returns
    -------
    dict with ``photon`` (P uint32, the photons of step 1), ``step`` (P int, first
    diverging step, 0 where the paths agree to the end), ``cause`` (P object:
    "fate", "place" or ""), ``approx_status``, ``exact_status`` (P int, the statuses
    at that step, -1 where a photon has no record), ``distance`` (P, metres between
    the end points at that step, nan where a record is missing), ``power_drift``
    (P, approx / exact power after that step − 1, mean over RGB), and ``options``.
    """
    approx, exact = _check(approx), _check(exact)
    if not place_tolerance >= 0:
        raise ValueError(f"place_tolerance = {place_tolerance!r}: expected a distance >= 0 (metres)")
    photons = np.asarray(approx[0]["photon"])
    if not np.array_equal(np.sort(photons), np.sort(np.asarray(exact[0]["photon"]))):
        raise ValueError("approx and exact: step 1 holds different photons (the replay must start from the "
                         "approximation's step-1 records)")
    n = len(photons)
    first = np.zeros(n, np.int64)
    cause = np.full(n, "", dtype=object)
    statuses = np.full((2, n), -1, np.int64)
    distance = np.full(n, np.nan)
    drift = np.full(n, np.nan)
    for k in range(max(len(approx), len(exact))):
        a = _by_photon(approx[k] if k < len(approx) else None, photons)
        e = _by_photon(exact[k] if k < len(exact) else None, photons)
        open_ = first == 0
        present = a["present"] | e["present"]
        fate = open_ & present & ((a["status"] != e["status"]) | (a["present"] != e["present"]))
        both = a["present"] & e["present"]
        gap = np.linalg.norm(a["end"] - e["end"], axis=1)
        place = open_ & ~fate & both & (gap > place_tolerance)
        new = fate | place
        first[new] = k + 1
        cause[fate] = CAUSE_FATE
        cause[place] = CAUSE_PLACE
        statuses[0, new], statuses[1, new] = a["status"][new], e["status"][new]
        distance[new & both] = gap[new & both]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = a["power"] / e["power"] - 1.0
        drift[new & both] = ratio[new & both]
    return {"photon": photons, "step": first, "cause": cause, "approx_status": statuses[0],
            "exact_status": statuses[1], "distance": distance, "power_drift": drift,
            "options": {"place_tolerance": place_tolerance, "status_names": dict(STATUS_NAMES)}}


def _by_photon(records, photons) -> dict:
    """Status, end point and power (mean RGB) of ``photons`` in one step's records."""
    n = len(photons)
    out = {"present": np.zeros(n, bool), "status": np.full(n, -1, np.int64), "end": np.full((n, 3), np.nan),
           "power": np.full(n, np.nan)}
    if records is None or len(records) == 0:
        return out
    order = np.argsort(records["photon"])
    keys = np.asarray(records["photon"])[order]
    index = np.searchsorted(keys, photons)
    found = (index < len(keys)) & (keys[np.minimum(index, len(keys) - 1)] == photons)
    rows = order[np.minimum(index, len(keys) - 1)][found]
    out["present"][found] = True
    out["status"][found] = records["status"][rows]
    out["end"][found] = records["end"][rows]
    out["power"][found] = _power(records["power"][rows])
    return out
