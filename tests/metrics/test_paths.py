"""metrics.paths on constructed photon histories with known budgets and divergences."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.metrics.paths import path_divergence, power_budget
from volcaustics.scenes.formats import RECORD_DTYPE, STATUS_COLLIDED, STATUS_LEFT_SCENE, STATUS_LOST, STATUS_SURFACE


def _step(step, photons, statuses, power_start, power, ends=None):
    r = np.zeros(len(photons), RECORD_DTYPE)
    r["photon"], r["step"], r["status"] = photons, step, statuses
    r["power_start"] = np.repeat(np.asarray(power_start, np.float64)[:, None], 3, axis=1)
    r["power"] = np.repeat(np.asarray(power, np.float64)[:, None], 3, axis=1)
    r["end"] = ends if ends is not None else np.zeros((len(photons), 3))
    return r


def _history():
    """Four photons of power 1. Step 1: 0 and 1 reach a surface (0.9 left), 2 collides
    (0.5), 3 is lost. Step 2: 0 collides (0.4), 1 leaves the scene (0.8)."""
    s1 = _step(1, [0, 1, 2, 3], [STATUS_SURFACE, STATUS_SURFACE, STATUS_COLLIDED, STATUS_LOST],
               [1, 1, 1, 1], [0.9, 0.9, 0.5, 1.0])
    s2 = _step(2, [0, 1, 2], [STATUS_COLLIDED, STATUS_LEFT_SCENE, STATUS_COLLIDED], [0.9, 0.9, 0.5],
               [0.4, 0.8, 0.3])
    return [s1, s2]


def test_power_budget_shares():
    rows = power_budget(_history(), tracer="exact")
    s1, s2, after = rows
    assert s1["step"] == 1 and s1["tracer"] == "exact" and s1["share_entering"] == pytest.approx(1.0)
    assert s1["share_surface"] == pytest.approx(1.8 / 4) and s1["share_collided"] == pytest.approx(0.5 / 4)
    assert s1["share_lost"] == pytest.approx(0.25) and s1["share_left_scene"] == 0
    assert s2["share_entering"] == pytest.approx(2.3 / 4)
    assert s2["share_collided"] == pytest.approx(0.7 / 4) and s2["share_left_scene"] == pytest.approx(0.2)
    # still on its way after step 2: the collided photons 0 and 2 go on (0.4 + 0.3)
    assert after["step"] == "after" and after["share_alive"] == pytest.approx(0.7 / 4)


def test_a_step_no_photon_reached_has_zero_shares():
    """Step 3 after every photon's path ended (photon_res 1, steps 32): zero rows, not
    "cannot reshape array of size 0"."""
    history = _history() + [_step(3, [], [], [], [])]
    rows = power_budget(history)
    assert rows[2]["step"] == 3 and rows[2]["share_entering"] == 0
    assert all(rows[2][f"share_{fate}"] == 0 for fate in ("surface", "collided", "lost", "left_scene"))
    assert rows[3] == {"tracer": "approx", "step": "after", "share_alive": 0.0}
    assert np.all(path_divergence(history, history)["step"] == 0)


def test_no_power_entering_gives_undefined_shares_not_an_error():
    """A spot that misses the glass or a tiny sphere no photon meets: no power enters
    step 1; the measurement crashed with a traceback after the reference had rendered
   . The shares are NaN (undefined)."""
    history = _history()
    for r in history:
        r["power_start"] = 0.0
        r["power"] = 0.0
    rows = power_budget(history)
    assert all(np.isnan(row["share_entering"]) for row in rows[:-1]) and np.isnan(rows[-1]["share_alive"])


def test_identical_paths_never_diverge():
    h = _history()
    d = path_divergence(h, h)
    assert np.all(d["step"] == 0) and np.all(d["cause"] == "") and np.all(np.isnan(d["distance"]))


def test_divergence_by_fate_and_by_place():
    exact = _history()
    approx = [r.copy() for r in exact]
    approx[0]["status"][3] = STATUS_SURFACE  # photon 3: the approximation found an exit the exact tracer did not
    approx[1]["end"][0] = [0.0, 0.0, 0.01]   # photon 0 ends 1 cm off at step 2, same fate
    approx[1]["end"][2] = [0.0, 0.0, 5e-4]   # photon 2: 0.5 mm off, within the tolerance
    approx[1]["power"][0] = 0.44             # 10% more power than its replay
    d = path_divergence(approx, exact, place_tolerance=1e-3)
    by = dict(zip(d["photon"].tolist(), range(4)))
    p3, p0, p2, p1 = by[3], by[0], by[2], by[1]
    assert d["step"][p3] == 1 and d["cause"][p3] == "fate"
    assert d["approx_status"][p3] == STATUS_SURFACE and d["exact_status"][p3] == STATUS_LOST
    assert d["step"][p0] == 2 and d["cause"][p0] == "place"
    assert d["distance"][p0] == pytest.approx(0.01) and d["power_drift"][p0] == pytest.approx(0.1)
    assert d["step"][p2] == 0 and d["step"][p1] == 0


def test_a_photon_missing_from_one_tracer_diverges_by_fate():
    exact = _history()
    approx = [exact[0].copy(), exact[1][exact[1]["photon"] != 1].copy()]  # photon 1 gone at step 2
    d = path_divergence(approx, exact)
    i = int(np.nonzero(d["photon"] == 1)[0][0])
    assert d["step"][i] == 2 and d["cause"][i] == "fate" and d["approx_status"][i] == -1


def test_bad_input():
    with pytest.raises(ValueError, match="none"):
        power_budget([])
    with pytest.raises(ValueError, match="missing fields"):
        power_budget([np.zeros(3, [("photon", "<u4")])])
    h = _history()
    with pytest.raises(ValueError, match="different photons"):
        path_divergence(h, [h[0][:2], h[1]])
    with pytest.raises(ValueError, match="place_tolerance"):
        path_divergence(h, h, place_tolerance=-1.0)
