"""Intersection error of the approximation per segment (pure numpy, float64).

docs/concepts/measuring.md → "Segments": for every segment the
approximation searched (its records of step k), the exact oracle answers on the
same interval (``reference.oracle.Oracle.first_hits(start, direction,
search_length)``; this module takes its answers as plain arrays). Each segment
gets one class:

==================  =========================================================
``TRUE_HIT``        both hit, |Δt| ≤ tolerance
``WRONG_SURFACE``   both hit, |Δt| > tolerance
``FALSE_HIT``       the approximation hits, the exact answer does not
``MISSED_INSIDE``   the exact answer hits, the approximation does not, and the
                    segment runs inside glass (the photon is lost)
``MISSED_MEDIUM``   the same in the medium
``CORRECT_MISS``    neither hits
``SELF_REHIT``      the exact first hit is the surface the segment starts on,
                    within the start offset (exact t ≤ start offset and, when
                    the start surface's normal is given, the exact hit's
                    geometric normal within ``self_normal_cos`` of it); reported
                    apart, never counted as a miss, whatever the approximation
                    found
==================  =========================================================

The tolerance is stated in light-map texel footprints at the hit and in metres:
``max(tolerance_texels · texel_angle · |hit − light_position|, tolerance_floor)``,
the hit point taken from the exact answer where it hits, else from the
approximation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

TRUE_HIT = 0
WRONG_SURFACE = 1
FALSE_HIT = 2
MISSED_INSIDE = 3
MISSED_MEDIUM = 4
CORRECT_MISS = 5
SELF_REHIT = 6

CLASS_NAMES = {TRUE_HIT: "true_hit", WRONG_SURFACE: "wrong_surface", FALSE_HIT: "false_hit",
               MISSED_INSIDE: "missed_inside", MISSED_MEDIUM: "missed_medium",
               CORRECT_MISS: "correct_miss", SELF_REHIT: "self_rehit"}
# what a segment's search came to; a self re-hit is resolved into one of these beyond its surface
OUTCOME_CLASSES = tuple(name for code, name in CLASS_NAMES.items() if code != SELF_REHIT)

RECORD_FIELDS = ("step", "start", "direction", "search_length", "start_offset", "t", "hit", "map",
                 "normal", "inside")
EXACT_FIELDS = ("hit", "t", "normal")

GROUP_KEYS = ("step", "map", "inside")
QUANTILES = (("median", 50.0), ("p90", 90.0), ("p99", 99.0))


def _field(container, name, what):
    try:
        return container[name]
    except (KeyError, ValueError, IndexError, TypeError):
        raise ValueError(f"{what} has no field {name!r}") from None


def _vectors(a, n, name):
    a = np.asarray(a, dtype=np.float64)
    if a.shape != (n, 3):
        raise ValueError(f"{name}: shape {a.shape}, expected ({n}, 3)")
    return a


def _scalars(a, n, name, dtype=np.float64):
    a = np.asarray(a, dtype=dtype)
    if a.shape != (n,):
        raise ValueError(f"{name}: shape {a.shape}, expected ({n},)")
    return a


def _check_hits(hit, t, name):
    if np.any(hit & ~np.isfinite(t)):
        raise ValueError(f"{name}: hit is set where t is not finite")


def _unit(v):
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / norm


def classify_segments(records: np.ndarray | Mapping[str, ArrayLike], exact: Mapping[str, ArrayLike], *,
                      texel_angle: float, light_position: ArrayLike, start_normal: ArrayLike | None = None,
                      tolerance_texels: float = 3.0, tolerance_floor: float = 1e-4, self_normal_cos: float = 0.9,
                      exact_beyond: Mapping[str, ArrayLike] | None = None) -> dict:
    """Class, Δt and normal error of every segment the approximation searched.

    Parameters
    ----------
    records : structured array, N
        The approximation's segment records (``scenes.formats.RECORD_DTYPE``, or
        anything with its fields ``step``, ``start`` (N×3, m), ``direction`` (N×3,
        unit), ``search_length`` (m), ``start_offset`` (m), ``t`` (m, nan
        without hit), ``hit``, ``map`` (2·layer + facing, -1), ``normal`` (N×3
        outward shading normal) and ``inside`` (-1 medium, else object id)).
        This is the "reference" side's partner: the test.
    exact : mapping of arrays
        The exact first hits on the same segments: ``hit`` (N bool), ``t`` (N,
        m, nan without hit), ``normal`` (N×3 outward shading normal) and, when
        present, ``geometric_normal`` (N×3, used for the self re-hit test;
        else ``normal`` is).
    texel_angle : float
        Angle of one light-map texel, rad (2·tan(cutoff) / light_res).
    light_position : array_like, 3
        The spot light's position, world, m.
    start_normal : array_like, N×3, optional
        Outward normal of the surface each segment starts on (nan or zero where
        it is not known). Without it (or where it is not known), every exact hit
        within the start offset counts as a self re-hit.
    tolerance_texels : float
        |Δt| tolerance in texel footprints at the hit (default 3).
    tolerance_floor : float
        Smallest tolerance, m (default 1e-4).
    self_normal_cos : float
        Smallest cosine between the exact hit's geometric normal and
        ``start_normal`` for a self re-hit (default 0.9).
    exact_beyond : mapping of arrays, optional
        For self re-hits: the exact first hits beyond the re-hit surface on the
        same segment (``hit``, ``t`` from the segment's start, ``normal``; other
        rows are ignored). A self re-hit hides what the approximation did with the
        rest of the segment; against these answers it gets a class too
        (``cls_beyond``).

    Returns
    -------
    dict
        ``cls`` (N int8, a class code, see ``CLASS_NAMES``); ``cls_beyond`` (N
        int8: for self re-hits with ``exact_beyond``, the class against what lies
        beyond the re-hit surface, else -1); ``dt`` (N float64,
        m, approx t − exact t, nan unless both hit); ``normal_error`` (N
        float64, rad, angle between approx and exact shading normals, nan
        unless both hit); ``tolerance`` (N float64, m, nan where neither hits);
        ``options`` (dict: every option used).

    Raises
    ------
    ValueError
        Missing fields, lengths or shapes that differ, hits without finite t,
        non-positive ``texel_angle`` or negative tolerances.
    """
    s = _segment_inputs(records, exact, start_normal)
    n, light = len(s["a_hit"]), np.asarray(light_position, dtype=np.float64)
    if light.shape != (3,):
        raise ValueError(f"light_position: shape {light.shape}, expected (3,)")
    if not (np.isfinite(texel_angle) and texel_angle > 0):
        raise ValueError(f"texel_angle must be positive, got {texel_angle}")
    if not (tolerance_texels >= 0 and tolerance_floor >= 0):
        raise ValueError(f"tolerances must be ≥ 0, got {tolerance_texels} texels, {tolerance_floor} m")
    tolerances = (texel_angle, light, tolerance_texels, tolerance_floor)
    cls, dt, normal_error, tolerance = _answer(s, s["e_hit"], s["e_t"], s["e_normal"], *tolerances)
    with np.errstate(invalid="ignore"):
        self_rehit = s["e_hit"] & (s["e_t"] <= s["start_offset"])
        if s["start_normal"] is not None:
            known = np.all(np.isfinite(s["start_normal"]), axis=1) & (np.linalg.norm(s["start_normal"], axis=1) > 0)
            same = np.einsum("ij,ij->i", _unit(s["e_geometric"]), _unit(s["start_normal"])) >= self_normal_cos
            self_rehit &= ~known | same
    cls[self_rehit] = SELF_REHIT

    cls_beyond = np.full(n, -1, np.int8)
    if exact_beyond is not None:
        b = {name: _field(exact_beyond, name, "exact_beyond") for name in EXACT_FIELDS}
        b_hit = _scalars(b["hit"], n, "exact_beyond hit", bool)
        b_t = _scalars(b["t"], n, "exact_beyond t")
        _check_hits(b_hit, b_t, "exact_beyond")
        beyond = _answer(s, b_hit, b_t, _vectors(b["normal"], n, "exact_beyond normal"), *tolerances)[0]
        cls_beyond[self_rehit] = beyond[self_rehit]

    options = {"texel_angle": float(texel_angle), "light_position": tuple(float(x) for x in light),
               "tolerance_texels": float(tolerance_texels), "tolerance_floor": float(tolerance_floor),
               "self_normal_cos": float(self_normal_cos), "start_normal_given": start_normal is not None,
               "beyond_self_rehit_given": exact_beyond is not None}
    return {"cls": cls, "cls_beyond": cls_beyond, "dt": dt, "normal_error": normal_error, "tolerance": tolerance,
            "options": options}


def _segment_inputs(records, exact, start_normal) -> dict:
    """The records' and the exact answers' fields as checked float64/bool/int arrays of one length."""
    step = np.asarray(_field(records, "step", "records"))
    n = step.shape[0] if step.ndim else -1
    if step.ndim != 1:
        raise ValueError(f"records: step has shape {step.shape}, expected (N,)")
    fields = {name: _field(records, name, "records") for name in RECORD_FIELDS}
    ex = {name: _field(exact, name, "exact") for name in EXACT_FIELDS}
    for name, v in ex.items():
        if len(np.asarray(v)) != n:
            raise ValueError(f"lengths differ: {n} records, exact {name!r} has {len(np.asarray(v))}")
    s = {"start": _vectors(fields["start"], n, "records start"),
         "direction": _vectors(fields["direction"], n, "records direction"),
         "start_offset": _scalars(fields["start_offset"], n, "records start_offset"),
         "a_hit": _scalars(fields["hit"], n, "records hit", bool), "a_t": _scalars(fields["t"], n, "records t"),
         "a_normal": _vectors(fields["normal"], n, "records normal"),
         "inside": _scalars(fields["inside"], n, "records inside", np.int64),
         "e_hit": _scalars(ex["hit"], n, "exact hit", bool), "e_t": _scalars(ex["t"], n, "exact t"),
         "e_normal": _vectors(ex["normal"], n, "exact normal")}
    s["e_geometric"] = (_vectors(exact["geometric_normal"], n, "exact geometric_normal")
                        if "geometric_normal" in exact else s["e_normal"])
    _check_hits(s["a_hit"], s["a_t"], "records")
    _check_hits(s["e_hit"], s["e_t"], "exact")
    s["start_normal"] = None if start_normal is None else _vectors(start_normal, n, "start_normal")
    return s


def _answer(s: dict, e_hit, e_t, e_normal, texel_angle, light, tolerance_texels, tolerance_floor) -> tuple:
    """Class (self re-hits not yet marked), Δt, normal error and tolerance of the
    approximation's segments ``s`` against one set of exact answers."""
    a_hit, a_t, inside = s["a_hit"], s["a_t"], s["inside"]
    # tolerance at the hit (exact where it hits, else approximate)
    t_hit = np.where(e_hit, e_t, np.where(a_hit, a_t, np.nan))
    point = s["start"] + t_hit[:, None] * s["direction"]
    tolerance = np.maximum(tolerance_texels * texel_angle * np.linalg.norm(point - light, axis=1), tolerance_floor)
    tolerance = np.where(np.isfinite(t_hit), tolerance, np.nan)
    both = a_hit & e_hit
    dt = np.where(both, a_t - e_t, np.nan)
    with np.errstate(invalid="ignore"):
        cos = np.einsum("ij,ij->i", _unit(s["a_normal"]), _unit(e_normal))
    normal_error = np.where(both, np.arccos(np.clip(cos, -1.0, 1.0)), np.nan)
    cls = np.full(len(a_hit), CORRECT_MISS, np.int8)
    cls[both & (np.abs(dt) <= tolerance)] = TRUE_HIT
    cls[both & ~(np.abs(dt) <= tolerance)] = WRONG_SURFACE
    cls[a_hit & ~e_hit] = FALSE_HIT
    cls[~a_hit & e_hit & (inside >= 0)] = MISSED_INSIDE
    cls[~a_hit & e_hit & (inside < 0)] = MISSED_MEDIUM
    return cls, dt, normal_error, tolerance


def _quantiles(values, prefix):
    v = values[np.isfinite(values)]
    return {f"{prefix}_{name}": (float(np.percentile(v, q)) if len(v) else float("nan"))
            for name, q in QUANTILES}


def _option_columns(options):
    out = {}
    for key, value in options.items():
        if key == "light_position":
            out.update({f"light_position_{axis}": v for axis, v in zip("xyz", value)})
        else:
            out[key] = value
    return out


def _unique_rows(columns: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """What ``np.unique(np.stack(columns, 1), axis=0, return_inverse=True)`` returns (the
    distinct rows in lexicographic order, each row's index among them), by one 1-D unique
    of a mixed-radix key of the columns' ranks: the rows' own unique sorts them as void
    records, 0.2 s on a frame's segments."""
    ranks = [np.unique(np.asarray(c), return_inverse=True) for c in columns]
    key = np.zeros(len(ranks[0][1]), np.int64)
    for values, rank in ranks:  # the first column most significant: the rows' lexicographic order
        key = key * len(values) + rank.reshape(-1)
    distinct, inverse = np.unique(key, return_inverse=True)
    digits, rest = [], distinct
    for values, _ in reversed(ranks):
        digits.append(values[rest % len(values)])
        rest = rest // len(values)
    groups = np.stack(digits[::-1], axis=1) if len(distinct) else np.zeros((0, len(columns)), np.int64)
    return groups, inverse.reshape(-1)


def intersection_table(records: np.ndarray | Mapping[str, ArrayLike], classes: dict, *,
                       group_by: Sequence[str] = GROUP_KEYS, parameters: dict | None = None) -> list:
    """Tidy rows of the segment classes, one per group.

    Parameters
    ----------
    records : structured array, N
        The records given to :func:`classify_segments` (fields ``step``,
        ``map``, ``inside``).
    classes : dict
        What :func:`classify_segments` returned for them.
    group_by : sequence of str
        Any of ``"step"``, ``"map"`` (the approximation's light map of the hit,
        -1 for segments it did not hit: misses, self re-hits without a hit)
        and ``"inside"`` (glass or medium). Default all three; ``()`` gives one
        row for everything.
    parameters : dict, optional
        More columns for every row (the scene and approximation parameters),
        so that a sweep is one groupby away from a plot.

    Returns
    -------
    list of dict
        One row per group, sorted by its key: ``step``, ``map``, ``layer``
        (map // 2), ``facing`` ("front"/"back"), ``inside`` ("glass"/"medium")
        — None for keys not grouped by, layer/facing None for map -1 —
        ``segments``, ``count_<class>`` and ``share_<class>`` for every class,
        ``count_beyond_self_rehit_<class>`` (the self re-hits by their class
        beyond the re-hit surface, when ``classes`` has them),
        ``abs_dt_{median,p90,p99}`` (m) and ``normal_error_{median,p90,p99}``
        (rad) over its true hits (nan without any), every option of
        ``classes`` and every entry of ``parameters``.
    """
    unknown = set(group_by) - set(GROUP_KEYS)
    if unknown:
        raise ValueError(f"group_by: unknown keys {sorted(unknown)}, expected some of {GROUP_KEYS}")
    for name in ("cls", "dt", "normal_error", "options"):
        if name not in classes:
            raise ValueError(f"classes has no entry {name!r}: pass what classify_segments returned")
    cls = np.asarray(classes["cls"])
    n = len(cls)
    beyond = classes.get("cls_beyond")
    beyond = None if beyond is None or not classes["options"].get("beyond_self_rehit_given") else np.asarray(beyond)
    keys = {"step": _scalars(_field(records, "step", "records"), n, "records step", np.int64),
            "map": _scalars(_field(records, "map", "records"), n, "records map", np.int64),
            "inside": _scalars(_field(records, "inside", "records"), n, "records inside", np.int64) >= 0}
    abs_dt = np.abs(np.asarray(classes["dt"], np.float64))
    normal_error = np.asarray(classes["normal_error"], np.float64)
    options = _option_columns(classes["options"])
    extra = dict(parameters or {})

    columns = [keys[k] for k in group_by]
    if columns:
        groups, inverse = _unique_rows(columns)
    else:
        groups, inverse = np.zeros((1 if n else 0, 0), np.int64), np.zeros(n, np.int64)

    rows = []
    for g, key in enumerate(groups):
        sel = inverse == g
        value = dict(zip(group_by, (int(x) for x in key)))
        m = value.get("map")
        row: dict[str, Any] = {"step": value.get("step"), "map": m,
               "layer": None if m is None or m < 0 else m // 2,
               "facing": None if m is None or m < 0 else ("front", "back")[m % 2],
               "inside": None if "inside" not in value else ("glass" if value["inside"] else "medium"),
               "segments": int(sel.sum())}
        c = cls[sel]
        for code, name in CLASS_NAMES.items():
            row[f"count_{name}"] = int(np.sum(c == code))
        for name in CLASS_NAMES.values():
            row[f"share_{name}"] = row[f"count_{name}"] / row["segments"]
        if beyond is not None:
            b = beyond[sel]
            for code, name in CLASS_NAMES.items():
                if code != SELF_REHIT:
                    row[f"count_beyond_self_rehit_{name}"] = int(np.sum(b == code))
        true = sel & (cls == TRUE_HIT)
        row.update(_quantiles(abs_dt[true], "abs_dt"))
        row.update(_quantiles(normal_error[true], "normal_error"))
        row.update(options)
        row.update(extra)
        rows.append(row)
    return rows
