"""Damaged caches of the reports (issue 21 C): metric noise floors and store points
are verified when read; a damaged one is recomputed, never used or shown."""

from __future__ import annotations

import json

import numpy as np
import pytest

from volcaustics.metrics import image as im
from volcaustics.reports.experiment import images

FLOOR_DAMAGES = {
    "NaN": '{"value": NaN}', "Infinity": '{"value": Infinity}', "null value": '{"value": null}',
    "a string": '{"value": "0.5"}', "true": '{"value": true}', "no value": "{}", "null": "null", "a list": "[1]",
    "garbage": "\0\xff{", "empty": "",
}


def _floor(keep, r, rv, component="caustic"):
    def compute(x, y):
        return im.per_pixel_relative_mse(x, y, mask=keep)["value"]

    return images.metric_floor("per_pixel_relative_mse", "k" * 32, component, keep, r, rv, compute)


@pytest.mark.parametrize("damage", [*FLOOR_DAMAGES, "another floor's file"])
def test_a_damaged_metric_floor_is_recomputed(tmp_path, monkeypatch, damage):
    """A cached floor holding NaN, ∞, no number, garbage or another floor's value is
    recomputed and rewritten (before: NaN made every debiased metric NaN, a string or
    another floor's number was used)."""
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path))
    monkeypatch.setattr(images, "_FLOORS", {})
    rng = np.random.default_rng(1)
    r = rng.uniform(0.1, 1.0, (12, 16, 3)).astype(np.float32)
    rv = (1e-2 * r).astype(np.float32)
    keep = np.ones((12, 16), bool)
    first = _floor(keep, r, rv)
    [path] = (tmp_path / "metric-floors").glob("*.json")
    if damage == "another floor's file":
        _floor(keep, r, 3 * rv, component="fog")
        [other] = [p for p in (tmp_path / "metric-floors").glob("*.json") if p != path]
        path.write_bytes(other.read_bytes())
        assert json.loads(other.read_text())["value"] != first
    else:
        path.write_text(FLOOR_DAMAGES[damage], encoding="utf-8", errors="surrogateescape")
    monkeypatch.setattr(images, "_FLOORS", {})  # a later process
    assert _floor(keep, r, rv) == first  # the floor's noise draws are seeded (FLOOR_SEED)
    assert json.loads(path.read_text())["value"] == first  # rewritten
