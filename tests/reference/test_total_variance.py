"""The reference's energy noise: each batch's image total is kept, so
the variance of an image's total is measured, not taken from Σ var as if its pixels were
independent — a light-tracer photon lands on many pixels (a medium segment is drawn
along its streak), and its pixels covary."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.reference.render import render_batches
from volcaustics.reference.render.batches import BatchStats, total_variance_ratio
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.scenes import load_builtin


def _images(rng, n, shape=(8, 8, 3)):
    return [{"x": rng.random(shape)} for _ in range(n)]


def test_totals_survive_the_cache_state_and_continue_batch_by_batch():
    """A state stored after 3 batches and continued with 3 more holds the totals of all 6
    at once; a state whose totals do not match its batch count is refused."""
    batches = _images(np.random.default_rng(1), 6)
    whole, first = BatchStats(("x",)), BatchStats(("x",))
    for b in batches:
        whole.add(b)
    for b in batches[:3]:
        first.add(b)
    resumed = BatchStats.from_arrays(("x",), first.arrays("s"), "s")
    for b in batches[3:]:
        resumed.add(b)
    assert np.array_equal(resumed.totals["x"], whole.totals["x"])
    assert np.allclose(whole.totals["x"], [b["x"].sum(axis=(0, 1)) for b in batches], rtol=1e-12)
    damaged = {**first.arrays("s"), "s/total/x": np.zeros((2, 3))}
    with pytest.raises(ValueError, match="batch totals"):
        BatchStats.from_arrays(("x",), damaged, "s")


def test_ratio_is_one_for_independent_pixels_and_the_pixel_count_for_shared_noise():
    """Independent pixel noise: the ratio estimates 1 (200 batches: its relative sampling
    error is √(2/199) ≈ 10%, 0.6–1.4 is 4 of them); noise one value shared by all 64
    pixels: the variance of the total is 64² σ² against Σ var = 64 σ², a ratio of 64
    (exactly, whatever the draws). A sum of two independent streams adds both."""
    rng = np.random.default_rng(2)
    independent, shared = BatchStats(("x",)), BatchStats(("x",))
    for _ in range(200):
        independent.add({"x": 1.0 + rng.standard_normal((8, 8, 3))})
        shared.add({"x": 1.0 + rng.standard_normal((1, 1, 3)) * np.ones((8, 8, 3))})
    assert all(0.6 < r < 1.4 for r in total_variance_ratio((independent, "x")))
    assert total_variance_ratio((shared, "x")) == pytest.approx([64.0] * 3, rel=1e-9)
    both = total_variance_ratio((independent, "x"), (shared, "x"))
    assert all(1.0 < r < 64.0 for r in both)
    assert total_variance_ratio((BatchStats(("x",), ), "x")) is None


@pytest.fixture(scope="module")
def bunny_batches():
    """The bunny's reference at 64² in 16 batches, with each light batch's image (a spy on
    BatchStats.add)."""
    seen = []
    original = BatchStats.add

    def spy(self, images, keep=None):
        if "caustic" in images:
            seen.append(np.asarray(images["caustic"], np.float64))
        original(self, images, keep)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(BatchStats, "add", spy)
        out = render_batches(load_builtin("bunny"), ReferenceSettings(photons=1 << 18, spp=16, batches=16, width=64,
                                                                      height=64), progress=False)
    return out, np.stack(seen)


def test_the_light_tracers_pixels_covary_and_the_ratio_carries_to_the_compared_pixels(bunny_batches):
    """On a real reference the caustic's ratio is far above 1 (measured ~20 at 128²,
    docs/decisions.md), while the camera integrator's fog, a pixel's samples its own, is
    within the 99.9% χ² bounds of a 1 from 16 batches (0.27–2.6). The totals are over
    the pixels the first camera batch sees free of glass; the metrics use the ratio for
    those all batches see free of it: the same batches give a ratio within 10% there
    (measured 2–8% on four built-ins at 64²; over all pixels it is 20–40% higher)."""
    out, light = bunny_batches
    ratios = out["_info"]["total_variance_ratio"]
    assert min(ratios["caustic"]) > 4
    assert all(0.27 < r < 2.6 for r in ratios["fog"])
    keep = out["mask_specular"][0][..., 0] < 0.5
    kept = light[:, keep]  # 16×N×3
    n = len(kept)
    over_keep = kept.sum(axis=1).var(axis=0, ddof=1) / n / (kept.var(axis=0, ddof=1).sum(axis=0) / n)
    assert over_keep == pytest.approx(ratios["caustic"], rel=0.1)


def test_groups_are_independent_estimates_that_continue_batch_by_batch():
    """The light stream's 8 groups: batch b in group b mod 8, their count-weighted mean is
    the mean, and a state stored after 5 batches and continued to 11 holds what 11 at once
    give; stored with another group count, the state is refused."""
    batches = _images(np.random.default_rng(3), 11)
    whole, first = BatchStats(("x",), groups=8), BatchStats(("x",), groups=8)
    for b in batches:
        whole.add(b)
    for b in batches[:5]:
        first.add(b)
    assert first.group_means("x") is None  # fewer batches than groups
    resumed = BatchStats.from_arrays(("x",), first.arrays("s"), "s", groups=8)
    for b in batches[5:]:
        resumed.add(b)
    means, counts = resumed.group_means("x")
    assert counts.tolist() == [2, 2, 2, 1, 1, 1, 1, 1]
    assert np.allclose(means[0], (batches[0]["x"] + batches[8]["x"]) / 2, rtol=1e-12)
    assert np.allclose(np.tensordot(counts, means, axes=1) / 11, whole.mean("x"), rtol=1e-12)
    with pytest.raises(ValueError, match="batch groups"):
        BatchStats.from_arrays(("x",), first.arrays("s"), "s", groups=4)


def test_a_cached_reference_gives_its_caustic_groups(tmp_path, empty_cache):
    """A reference from the cache reads its groups from its batch state: 8 groups of one
    batch each at 8 batches whose mean is the caustic layer (float32 of the float64
    mean); with 4 batches there are none (None: the metrics take pixels as independent)."""
    from volcaustics.reference.render import render_reference

    scene = load_builtin("sphere1")
    few = render_reference(scene, ReferenceSettings(photons=1 << 15, spp=8, batches=4, width=32, height=32),
                           progress=False)
    assert few.groups("caustic") is None
    result = render_reference(scene, ReferenceSettings(photons=1 << 16, spp=16, batches=8, width=32, height=32),
                              progress=False)
    means, counts = result.groups("caustic")
    assert counts.tolist() == [1] * 8
    assert np.allclose(means.mean(axis=0), result.mean["caustic"], rtol=1e-6, atol=1e-12)
    orders = render_reference(scene, ReferenceSettings(photons=1 << 15, spp=8, batches=8, width=32, height=32,
                                                       max_scatter=2), progress=False)
    for layer in ("caustic_ms", "fog_ms"):  # the model terms' groups, from the orders stream
        means, counts = orders.groups(layer)
        assert counts.sum() == 8 and np.allclose(means.mean(axis=0), orders.mean[layer], rtol=1e-6, atol=1e-12)
    assert orders.groups("fog@2") is None  # one order's image keeps no groups
