"""The image metrics are a registry (``image_rows.METRICS``): a metric registered by name
is measured on every point's images with no other edit, its error map kept when it has
one, and every map the report draws has a colour scale."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.experiment import image_rows as images
from volcaustics.reference.cache import ReferenceResult
from volcaustics.reports.presenting.figures.scales import SCALES


def _max_abs(reference, frame, *, mask=None, full=False):
    error = np.abs(np.asarray(frame) - reference).max(axis=-1)
    out = {"value": float(error[mask].max())}
    if full:
        out["map"] = np.where(mask, error, np.nan)
    return out


def _reference(mean):
    layers = {"caustic": mean, "caustic_var": np.full_like(mean, 1e-6)}
    key = "k" * 32
    return ReferenceResult(key, {"files": {"exr": f"{key}.r.exr", "png": f"{key}.r.png"}}, True, layers)


class _Frame:
    def __init__(self, caustic):
        self.images = {"caustic": caustic}


@pytest.fixture
def registry(monkeypatch):
    monkeypatch.setattr(images, "METRICS", dict(images.METRICS))  # a registration is undone after the test
    return images.METRICS


def test_a_registered_metric_is_measured_and_its_map_kept(registry, empty_cache):
    images.register_metric(images.per_frame_metric("max_abs_error", _max_abs, lambda m, f: m - f, error_map=True))
    rng = np.random.default_rng(1)
    r = rng.uniform(0.5, 1.0, (16, 16, 3)).astype(np.float32)
    keep = np.ones((16, 16), bool)
    good = [_Frame(r + 0.01), _Frame(r - 0.01)]
    wrong = [_Frame(r * 2.0), _Frame(r * 2.0)]  # negative control: frames twice too bright
    maps: dict = {}
    rows, head = images.image_rows(good, _reference(r), keep, {"reference_key": "k" * 32}, maps=maps,
                                   components=("caustic",))
    assert [row["metric"] for row in rows] == list(registry)  # every registered metric, in order
    assert head["caustic"]["max_abs_error"]["value"] == pytest.approx(0.01, rel=1e-3)
    assert ("max_abs_error", "caustic") in maps and "max_abs_error" in images.map_metrics()
    rows, head = images.image_rows(wrong, _reference(r), keep, {"reference_key": "k" * 32},
                                   components=("caustic",), metrics=("max_abs_error",))
    assert [row["metric"] for row in rows] == ["max_abs_error"]
    assert head["caustic"]["max_abs_error"]["value"] == pytest.approx(float(r.max()), rel=1e-3)


def test_a_metric_name_is_registered_once(registry):
    with pytest.raises(ValueError, match="already registered"):
        images.register_metric(images.ImageMetric("ssim", lambda x: {}))


def test_every_error_map_has_a_colour_scale():
    """A metric that keeps a map needs a scale to be drawn (docs/howto/add-metric.md)."""
    assert set(images.map_metrics()) <= set(SCALES)
    assert set(images.IMAGE_METRICS) == set(images.METRICS)
