"""Damaged caches of the reports: metric noise floors and store points
are verified when read; a damaged one is recomputed, never used or shown."""

from __future__ import annotations

import json

import numpy as np
import pytest

from volcaustics.experiment import image_rows as images
from volcaustics.metrics import image as im

FLOOR_DAMAGES = {
    "NaN": '{"value": NaN}', "Infinity": '{"value": Infinity}', "null value": '{"value": null}',
    "a string": '{"value": "0.5"}', "true": '{"value": true}', "no value": "{}", "null": "null", "a list": "[1]",
    "garbage": "\0\xff{", "empty": "",
}


def _floor(keep, r, rv, component="caustic"):
    def compute(x, y):
        return im.per_pixel_relative_mse(x, y, mask=keep)["value"]

    return images.metric_floor("per_pixel_relative_mse", "k" * 32, component, keep, r, rv, compute)


@pytest.mark.parametrize("damage", [*FLOOR_DAMAGES, "another floor's file", "its value edited"])
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
    elif damage == "its value edited":  # the hostile pass: 0.073 → 0.5 with the ident kept was served
        doc = json.loads(path.read_text())
        path.write_text(json.dumps({**doc, "value": 0.5}))
    else:
        path.write_text(FLOOR_DAMAGES[damage], encoding="utf-8", errors="surrogateescape")
    monkeypatch.setattr(images, "_FLOORS", {})  # a later process
    assert _floor(keep, r, rv) == first  # the floor's noise draws are seeded (FLOOR_SEED)
    assert json.loads(path.read_text())["value"] == first  # rewritten


class _Experiment:
    """What ``Store.write_point`` stores: three tables of rows and a summary."""

    def __init__(self, value: float):
        self.segments = [{"step": 0, "count": 10}]
        self.photons = [{"photons": 1000}]
        self.images = [{"component": "caustic", "metric": "relative_mse", "value": value}]
        self.summary = {"scene": "refocus", "images": {"caustic": {"relative_mse": {"value": value}}}}


@pytest.mark.parametrize("damage", ["a number edited", "a key added", "the hash edited", "the hash removed",
                                    "the hash not text"])
def test_an_edited_point_summary_counts_as_damaged(tmp_path, damage):
    """A point's summary.json carries the SHA-256 of its own content: one edited by
    hand (a number, a key), or without that hash (a store written before it), is
    damaged: recomputed by a sweep or the report, never read (before: an edited number
    was shown on the page)."""
    from volcaustics.reports.measuring.results.store import SUMMARY, Store

    store = Store(str(tmp_path / "store"))
    key = "0123456789abcdef0123456789abcdef"
    assert store.write_point(key, {"format": 1}, _Experiment(0.5)) == "written"
    assert store.status(key) == "done" and store.summary(key)["images"]["caustic"]["relative_mse"]["value"] == 0.5
    path = tmp_path / "store" / "points" / key / SUMMARY
    summary = json.loads(path.read_text())
    if damage == "a number edited":
        summary["images"]["caustic"]["relative_mse"]["value"] = 0.05
    elif damage == "a key added":
        summary["note"] = "checked by hand"
    elif damage == "the hash edited":
        summary["summary_sha256"] = "0" * 64
    elif damage == "the hash removed":
        del summary["summary_sha256"]
    else:
        summary["summary_sha256"] = None
    path.write_text(json.dumps(summary, indent=1))
    assert store.summary(key) is None and store.status(key) == "damaged"
    assert len(store.tables([key])["points"]) == 0
    assert store.write_point(key, {"format": 1}, _Experiment(0.5)) == "written"  # the damaged copy is replaced
    assert store.status(key) == "done"



def test_a_metric_floor_outlives_a_change_to_the_renderers(tmp_path, monkeypatch):
    """A floor is the reference against its own noisy copy: its key holds the metrics'
    code (metrics/ and experiment/image_rows.py), not the renderers', so the floors
    cached before a shader or exact-replay change still serve; a change to the metrics
    computes them again."""
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path))
    r = np.random.default_rng(2).uniform(0.1, 1.0, (12, 16, 3)).astype(np.float32)
    rv, keep = 1e-2 * r, np.ones((12, 16), bool)
    monkeypatch.setattr(images, "_FLOORS", {})
    first = _floor(keep, r, rv)
    real = images.code_version

    def floor_with(changed):  # a later process in which the code of ``changed`` differs
        monkeypatch.setattr(images, "_FLOORS", {})
        monkeypatch.setattr(images, "code_version", lambda folders: real(folders) if folders != changed else "new")
        images.floor_code_version.cache_clear()
        computed = []
        value = images.metric_floor("per_pixel_relative_mse", "k" * 32, "caustic", keep, r, rv,
                                    lambda x, y: computed.append(1) or 0.5)
        return value, computed

    try:
        assert floor_with(("approx", "reference")) == (first, [])
        assert floor_with(("metrics",)) == (0.5, [1] * images.FLOOR_DRAWS)
    finally:
        images.floor_code_version.cache_clear()

@pytest.mark.parametrize("schema, readable", [(None, True), (1, True), (2, False), (True, False), ("1", False)])
def test_a_stored_point_of_another_summary_schema_is_measured_again(tmp_path, schema, readable):
    """The store reads experiment summaries of this code's schema only (``SCHEMAS``): a
    summary without the field predates it and is schema 1 (it loads); one of another
    schema, sealed as it would be by that code, counts as damaged and is measured again,
    never misread."""
    from volcaustics.reports.measuring.results.store import SUMMARY, Store, sealed

    store = Store(str(tmp_path / "store"))
    key = "0123456789abcdef0123456789abcdef"
    assert store.write_point(key, {"format": 1}, _Experiment(0.5)) == "written"
    path = tmp_path / "store" / "points" / key / SUMMARY
    summary = {k: v for k, v in json.loads(path.read_text()).items() if k not in ("schema", "summary_sha256")}
    if schema is not None:
        summary["schema"] = schema
    path.write_text(json.dumps(sealed(summary), indent=1))
    assert (store.status(key) == "done") is readable
    assert (store.summary(key) is not None) is readable
