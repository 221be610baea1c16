"""metrics.intersection on analytic segments whose classes are known: a plane
z = PLANE at a known distance below the start, a light at the origin."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.metrics import intersection as ix
from volcaustics.scenes.formats import RECORD_DTYPE

LIGHT = (0.0, 0.0, 0.0)
TEXEL = 1e-3         # rad per texel
PLANE = 1.0          # the plane z = 1, hit at t = 1 from z = 0 going +z
UP = (0.0, 0.0, -1.0)  # the plane's outward normal (facing the light)


def _records(n, *, t=np.nan, hit=False, inside=-1, start=(0.0, 0.0, 0.0), search=2.0, offset=0.0,
             step=1, map_=-1, normal=UP):
    r = np.zeros(n, RECORD_DTYPE)
    r["step"] = step
    r["start"] = start
    r["direction"] = (0.0, 0.0, 1.0)
    r["search_length"] = search
    r["max_length"] = search
    r["start_offset"] = offset
    r["t"] = t if hit else np.nan
    r["hit"] = hit
    r["map"] = map_ if hit else -1
    r["normal"] = normal if hit else np.nan
    r["inside"] = inside
    r["material"] = -1
    return r


def _exact(n, *, t=np.nan, hit=False, normal=UP):
    return {"hit": np.full(n, hit), "t": np.full(n, t if hit else np.nan),
            "normal": np.tile(np.where(hit, normal, np.nan), (n, 1)),
            "geometric_normal": np.tile(np.where(hit, normal, np.nan), (n, 1)),
            "shape": np.full(n, 0 if hit else -1)}


def _cat(*parts):
    recs = np.concatenate([p[0] for p in parts])
    ex = {k: np.concatenate([p[1][k] for p in parts]) for k in parts[0][1]}
    return recs, ex


def _classify(recs, ex, **kw):
    kw.setdefault("texel_angle", TEXEL)
    kw.setdefault("light_position", LIGHT)
    return ix.classify_segments(recs, ex, **kw)


def test_plane_true_hit_and_wrong_surface():
    # tolerance at the hit (0, 0, 1): 3 texels · 1e-3 rad · 1 m = 3 mm
    near = _records(1, t=PLANE + 0.002, hit=True, map_=0), _exact(1, t=PLANE, hit=True)
    far = _records(1, t=PLANE + 0.004, hit=True, map_=0), _exact(1, t=PLANE, hit=True)
    out = _classify(*_cat(near, far))
    assert list(out["cls"]) == [ix.TRUE_HIT, ix.WRONG_SURFACE]
    np.testing.assert_allclose(out["tolerance"], 0.003, rtol=1e-12)
    np.testing.assert_allclose(out["dt"], [0.002, 0.004], atol=1e-6)  # float32 t
    np.testing.assert_allclose(out["normal_error"], 0.0, atol=1e-7)


def test_correct_miss_when_segment_ends_before_surface():
    # searched 0.5 m, plane at 1 m: the exact answer is no hit, nor is the approximation's
    out = _classify(_records(1, search=0.5), _exact(1))
    assert out["cls"][0] == ix.CORRECT_MISS
    assert np.isnan(out["dt"][0]) and np.isnan(out["tolerance"][0])


def test_false_hit():
    out = _classify(_records(1, t=0.4, hit=True, search=0.5, map_=2), _exact(1))
    assert out["cls"][0] == ix.FALSE_HIT
    assert np.isnan(out["dt"][0]) and np.isnan(out["normal_error"][0])
    np.testing.assert_allclose(out["tolerance"][0], 3 * TEXEL * 0.4, rtol=1e-6)  # from the approx hit


def test_missed_inside_glass_vs_medium():
    glass = _records(1, inside=2), _exact(1, t=PLANE, hit=True)
    medium = _records(1, inside=-1), _exact(1, t=PLANE, hit=True)
    out = _classify(*_cat(glass, medium))
    assert list(out["cls"]) == [ix.MISSED_INSIDE, ix.MISSED_MEDIUM]


def test_self_rehit_on_start_surface_only():
    # start on the plane's far side going +z... here: start 1 mm before a surface whose
    # normal is the start surface's (self), or a perpendicular one (another surface)
    offset = 0.005
    start_n = np.array([UP])
    own = _records(1, offset=offset, inside=1), _exact(1, t=0.001, hit=True, normal=UP)
    other = _records(1, offset=offset, inside=1), _exact(1, t=0.001, hit=True, normal=(1.0, 0.0, 0.0))
    beyond = _records(1, offset=offset, inside=1), _exact(1, t=0.01, hit=True, normal=UP)
    recs, ex = _cat(own, other, beyond)
    out = _classify(recs, ex, start_normal=np.repeat(start_n, 3, axis=0))
    assert list(out["cls"]) == [ix.SELF_REHIT, ix.MISSED_INSIDE, ix.MISSED_INSIDE]
    # a self re-hit stays one when the approximation hit something further on
    recs2 = _records(1, offset=offset, inside=1, t=0.3, hit=True, map_=1)
    out2 = _classify(recs2, _exact(1, t=0.001, hit=True), start_normal=start_n)
    assert out2["cls"][0] == ix.SELF_REHIT
    # without start normals, within the offset is enough
    out3 = _classify(recs, ex)
    assert list(out3["cls"]) == [ix.SELF_REHIT, ix.SELF_REHIT, ix.MISSED_INSIDE]
    assert out["options"]["start_normal_given"] and not out3["options"]["start_normal_given"]


def test_unknown_start_normal_falls_back_to_the_offset_rule():
    """Where a segment's start normal is unknown (nan: step 1 starts where the
    emission met the glass, which no record holds), within the offset is enough;
    where it is known, the exact hit must face the same way."""
    offset = 0.005
    other_surface = (1.0, 0.0, 0.0)
    recs = np.concatenate([_records(1, offset=offset, inside=1)] * 2)
    ex = _exact(2, t=0.001, hit=True, normal=other_surface)
    start_n = np.array([[np.nan, np.nan, np.nan], UP])
    out = _classify(recs, ex, start_normal=start_n)
    assert list(out["cls"]) == [ix.SELF_REHIT, ix.MISSED_INSIDE]


def test_beyond_a_self_rehit_the_segment_is_classified_too():
    """A self re-hit hides what the approximation did with the rest of its segment:
    against the exact answer beyond the re-hit surface (the plane at 1 m) an
    approximate hit 2 mm off is a true hit, no hit is a miss; rows that are not self
    re-hits have no such class (-1), and the table counts the self re-hits by it."""
    offset = 0.005
    found = _records(1, offset=offset, inside=1, t=PLANE + 0.002, hit=True, map_=1), _exact(1, t=0.001, hit=True)
    missed = _records(1, offset=offset, inside=1), _exact(1, t=0.001, hit=True)
    plain = _records(1, t=PLANE, hit=True, map_=0), _exact(1, t=PLANE, hit=True)
    recs, ex = _cat(found, missed, plain)
    beyond = _exact(3, t=PLANE, hit=True)
    out = _classify(recs, ex, exact_beyond=beyond)
    assert list(out["cls"]) == [ix.SELF_REHIT, ix.SELF_REHIT, ix.TRUE_HIT]
    assert list(out["cls_beyond"]) == [ix.TRUE_HIT, ix.MISSED_INSIDE, -1]
    (row,) = ix.intersection_table(recs, out, group_by=())
    assert row["count_self_rehit"] == 2 and row["count_beyond_self_rehit_true_hit"] == 1
    assert row["count_beyond_self_rehit_missed_inside"] == 1 and row["count_beyond_self_rehit_correct_miss"] == 0
    assert "count_beyond_self_rehit_true_hit" not in ix.intersection_table(recs, _classify(recs, ex), group_by=())[0]


def test_tolerance_scales_with_distance_from_light():
    # the same Δt = 5 mm: wrong surface 1 m from the light (tol 3 mm), true hit 2 m away (6 mm)
    near = _records(1, t=1.005, hit=True, map_=0), _exact(1, t=1.0, hit=True)
    far = _records(1, start=(0, 0, 1.0), t=1.005, hit=True, map_=0), _exact(1, t=1.0, hit=True)
    out = _classify(*_cat(near, far))
    np.testing.assert_allclose(out["tolerance"], [0.003, 0.006], rtol=1e-12)
    assert list(out["cls"]) == [ix.WRONG_SURFACE, ix.TRUE_HIT]
    # the floor wins close to the light
    close = _classify(_records(1, t=0.01, hit=True, map_=0), _exact(1, t=0.01, hit=True),
                      tolerance_floor=1e-3)
    assert close["tolerance"][0] == pytest.approx(1e-3)


def _mixed(rng, n=400):
    recs = np.zeros(n, RECORD_DTYPE)
    recs["step"] = rng.integers(1, 4, n)
    recs["start"] = rng.normal(size=(n, 3))
    d = rng.normal(size=(n, 3))
    recs["direction"] = d / np.linalg.norm(d, axis=1, keepdims=True)
    recs["search_length"] = 2.0
    recs["start_offset"] = 0.01
    recs["inside"] = rng.choice([-1, 0, 3], n)
    a_hit = rng.random(n) < 0.6
    e_hit = rng.random(n) < 0.6
    e_t = np.where(e_hit, rng.uniform(0.0, 2.0, n), np.nan)
    recs["hit"] = a_hit
    recs["t"] = np.where(a_hit, np.where(e_hit, e_t + rng.normal(0, 0.003, n), rng.uniform(0, 2, n)), np.nan)
    recs["map"] = np.where(a_hit, rng.integers(0, 8, n), -1)
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    recs["normal"] = np.where(a_hit[:, None], nrm, np.nan)
    ex = {"hit": e_hit, "t": e_t, "normal": np.where(e_hit[:, None], nrm, np.nan)}
    return recs, ex


def test_grouping_counts_sum_to_total():
    recs, ex = _mixed(np.random.default_rng(1))
    out = _classify(recs, ex)
    rows = ix.intersection_table(recs, out, parameters={"scene": "plane", "layers": 4})
    assert sum(r["segments"] for r in rows) == len(recs)
    for code, name in ix.CLASS_NAMES.items():
        assert sum(r[f"count_{name}"] for r in rows) == np.sum(out["cls"] == code)
    for r in rows:
        assert sum(r[f"count_{name}"] for name in ix.CLASS_NAMES.values()) == r["segments"]
        assert sum(r[f"share_{name}"] for name in ix.CLASS_NAMES.values()) == pytest.approx(1.0)
        # every option and parameter in every row
        assert r["tolerance_texels"] == 3.0 and r["texel_angle"] == TEXEL and r["scene"] == "plane"
        assert r["light_position_z"] == 0.0 and r["layers"] == 4
        if r["map"] >= 0:
            assert r["layer"] == r["map"] // 2 and r["facing"] == ("front", "back")[r["map"] % 2]
        else:
            assert r["count_true_hit"] == r["count_wrong_surface"] == r["count_false_hit"] == 0
    keys = {(r["step"], r["map"], r["inside"]) for r in rows}
    assert len(keys) == len(rows)
    # coarser grouping: per step
    by_step = ix.intersection_table(recs, out, group_by=("step",))
    assert [r["step"] for r in by_step] == [1, 2, 3]
    assert [r["segments"] for r in by_step] == [int(np.sum(recs["step"] == s)) for s in (1, 2, 3)]
    assert all(r["map"] is None and r["inside"] is None for r in by_step)
    (total,) = ix.intersection_table(recs, out, group_by=())
    true = out["cls"] == ix.TRUE_HIT
    assert total["abs_dt_median"] == pytest.approx(np.median(np.abs(out["dt"][true])))
    assert total["abs_dt_p99"] == pytest.approx(np.percentile(np.abs(out["dt"][true]), 99))


def test_identity_exact_against_itself():
    recs, ex = _mixed(np.random.default_rng(2))
    recs["start_offset"] = 0.0  # the exact tracer's records start at the surface
    recs["hit"] = ex["hit"]
    recs["t"] = ex["t"]
    recs["normal"] = ex["normal"]
    ex = {k: v for k, v in ex.items()}
    ex["t"] = recs["t"].astype(np.float64)  # the same float32 values
    out = _classify(recs, ex)
    assert set(np.unique(out["cls"])) <= {ix.TRUE_HIT, ix.CORRECT_MISS}
    assert np.all(out["cls"][ex["hit"]] == ix.TRUE_HIT)
    assert np.all(out["dt"][ex["hit"]] == 0.0)
    np.testing.assert_allclose(out["normal_error"][ex["hit"]], 0.0, atol=1e-3)
    (total,) = ix.intersection_table(recs, out, group_by=())
    assert total["abs_dt_p99"] == 0.0 and total["share_true_hit"] == pytest.approx(ex["hit"].mean())


def test_bad_input_raises():
    recs, ex = _mixed(np.random.default_rng(3), n=10)
    with pytest.raises(ValueError, match="lengths differ"):
        _classify(recs[:9], ex)
    with pytest.raises(ValueError, match="no field 'normal'"):
        _classify(recs, {"hit": ex["hit"], "t": ex["t"]})
    with pytest.raises(ValueError, match="no field 'start_offset'"):
        from numpy.lib import recfunctions as rfn
        _classify(rfn.drop_fields(recs, "start_offset", usemask=False), ex)
    with pytest.raises(ValueError, match="light_position"):
        _classify(recs, ex, light_position=(0.0, 0.0))
    with pytest.raises(ValueError, match="texel_angle"):
        _classify(recs, ex, texel_angle=0.0)
    with pytest.raises(ValueError, match="start_normal"):
        _classify(recs, ex, start_normal=np.zeros((9, 3)))
    bad = dict(ex, t=np.where(ex["hit"], np.nan, ex["t"]))
    with pytest.raises(ValueError, match="hit is set where t is not finite"):
        _classify(recs, bad)
    with pytest.raises(ValueError, match="group_by"):
        ix.intersection_table(recs, _classify(recs, ex), group_by=("photon",))


def test_the_groups_are_numpys_distinct_rows_in_order():
    """The table's groups (one 1-D unique of a key of the columns' ranks) are what numpy's
    unique of the (step, map, inside) rows gives: the same rows in lexicographic order, each
    with its records' count; map −1 and the boolean inside column included."""
    recs, ex = _mixed(np.random.default_rng(7))
    rows = ix.intersection_table(recs, _classify(recs, ex))
    table = np.stack([recs["step"].astype(np.int64), recs["map"].astype(np.int64), recs["inside"] >= 0], axis=1)
    want, counts = np.unique(table, axis=0, return_counts=True)
    assert [(r["step"], r["map"], r["inside"] == "glass") for r in rows] == [tuple(int(x) for x in w) for w in want]
    assert [r["segments"] for r in rows] == counts.tolist()
    assert -1 in want[:, 1] and len(set(want[:, 2])) == 2  # the cases the key must order: a miss, both sides
