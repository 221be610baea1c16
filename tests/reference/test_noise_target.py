"""The noise floor as a first-class output: renders to a target floor with
photon and time caps, continuation of cached entries batch by batch, and what "same
seed, same reference" means."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from volcaustics.metrics.noise import noise_floor
from volcaustics.reference.render import render_batches, render_reference
from volcaustics.reference.render import tasks as render_tasks
from volcaustics.reference.settings import ReferenceSettings, SettingsError
from volcaustics.reports.cli import main
from volcaustics.scenes import load_builtin

# 32², 2^14 photons and 4 camera samples per pixel a batch: a batch takes milliseconds
BASE = ReferenceSettings(photons=1 << 16, spp=16, batches=4, width=32, height=32)


@pytest.fixture
def rendered_batches(monkeypatch):
    """(stream, batch) of every batch rendered, in order."""
    seen = []
    original = render_tasks.batch_seed

    def spy(seed, stream, batch):
        seen.append((stream, batch))
        return original(seed, stream, batch)

    monkeypatch.setattr(render_tasks, "batch_seed", spy)
    return seen


def _floors_from_images(result) -> dict:
    keep = result.mean["mask_specular"][..., 0] < 0.5
    return {name: noise_floor(result.mean[name], result.var[name], mask=keep) for name in ("caustic", "fog", "direct")}


def test_target_noise_renders_until_every_floor_is_met(empty_cache):
    scene = load_builtin("refocus")
    target = {"caustic": 0.01, "fog": 0.004, "direct": 0.05}
    result = render_reference(scene, dataclasses.replace(BASE, target_noise=target), progress=False)
    m = result.manifest
    assert m["stopped_by"] == "target"
    # the manifest's floors are the images' (metrics.noise.noise_floor: one definition)
    from_images = _floors_from_images(result)
    for name, value in target.items():
        assert m["noise_floor"][name] <= value
        assert from_images[name] == pytest.approx(m["noise_floor"][name], rel=1e-4)  # float32 EXR vs float64
        assert 0 < m["seconds_to_target"][name]["seconds"] <= m["wall_seconds"]
    # more batches than the minimum were needed (the fog floor at 4 batches is above 0.4%)
    assert m["camera_batches"] > BASE.batches


def test_caps_stop_a_target_that_cannot_be_met(empty_cache):
    scene = load_builtin("refocus")
    unreachable = dataclasses.replace(BASE, target_noise="caustic=1e-7")
    capped = render_reference(scene, dataclasses.replace(unreachable, max_photons=6 * (1 << 14)), progress=False)
    assert capped.manifest["stopped_by"] == "photon cap"
    assert capped.manifest["photons"] <= 6 * (1 << 14) and capped.manifest["batches"] == 6
    assert capped.manifest["photon_spp_per_batch"] * 32 * 32 == 1 << 14  # 2^16 photons over 4 batches
    timed = render_reference(load_builtin("sphere1"), dataclasses.replace(unreachable, max_seconds=0.5),
                             progress=False)
    assert timed.manifest["stopped_by"] == "time cap"
    assert timed.manifest["noise_floor"]["caustic"] > 1e-7


def test_cached_entry_is_continued_not_rerendered(empty_cache, rendered_batches):
    """An entry with fewer batches (or a higher floor) than asked is continued: only the
    missing batches render, and the result is that of rendering them all at once."""
    scene = load_builtin("bunny")
    first = render_reference(scene, BASE, progress=False)
    assert sorted(rendered_batches) == sorted((s, b) for s in ("light", "camera") for b in range(4))
    rendered_batches.clear()
    more = dataclasses.replace(BASE, photons=2 * BASE.photons, spp=2 * BASE.spp, batches=8)  # same batch size
    second = render_reference(scene, more, progress=False)
    assert not second.cached and second.key == first.key
    assert sorted(rendered_batches) == sorted((s, b) for s in ("light", "camera") for b in range(4, 8))
    assert second.manifest["batches"] == 8 and second.manifest["wall_seconds"] > first.manifest["wall_seconds"]
    # a lower target on the continued entry also continues it, and a met one is served
    assert render_reference(scene, BASE, progress=False).cached
    fresh = render_batches(scene, more, progress=False)
    for name in ("fog", "direct"):
        assert np.array_equal(second.mean[name], fresh[name][0])
        assert np.array_equal(second.var[name], fresh[name][1])
    _assert_float32_atomics_only(second.mean["caustic"], fresh["caustic"][0])
    # the batch totals continue too (the reference's energy noise, tests/reference/test_total_variance.py)
    ratios, fresh_ratios = second.manifest["total_variance_ratio"], fresh["_info"]["total_variance_ratio"]
    assert ratios["fog"] == fresh_ratios["fog"]
    assert ratios["caustic"] == pytest.approx(fresh_ratios["caustic"], rel=1e-3)


def _assert_float32_atomics_only(a, b):
    """The light tracer splats into Mitsuba's float32 image block with atomic adds from
    Dr.Jit's worker threads, in whatever order they run; float addition is not
    associative, so the last bits of a pixel depend on that order (Higham: |Δ| ≤
    2(n−1)·u·Σ|x| for n splats, u = 2^-24). Allowed: 1e-5 relative (≈ 170 ulps), far
    above what was measured and far below any noise floor (≥ 1e-4 relative per pixel
    here; docs/decisions.md "Float32 atomic splats")."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    assert np.all(np.abs(a - b) <= 1e-5 * np.maximum(np.abs(a), np.abs(b)))


def test_same_seed_same_reference_different_seed_another(empty_cache):
    scene = load_builtin("bunny")
    a = render_batches(scene, BASE, progress=False)
    b = render_batches(scene, BASE, progress=False)
    c = render_batches(scene, dataclasses.replace(BASE, seed=1), progress=False)
    for name in ("fog", "direct", "mask_specular"):  # the camera integrator is bit-identical
        assert np.array_equal(a[name][0], b[name][0])
    _assert_float32_atomics_only(a["caustic"][0], b["caustic"][0])
    assert not np.array_equal(a["fog"][0], c["fog"][0])
    assert np.abs(a["caustic"][0] - c["caustic"][0]).max() > 1e-3 * a["caustic"][0].max()


def test_target_noise_settings_and_cli(tmp_path, empty_cache, capsys):
    assert ReferenceSettings(target_noise=0.01).targets() == {"caustic": 0.01, "fog": 0.01, "direct": 0.01}
    assert ReferenceSettings(target_noise="caustic=0.005,direct=0.002").targets() == {"caustic": 0.005,
                                                                                     "direct": 0.002}
    for bad in ("fog=2", "smoke=0.1", "x", 0, -0.1, "fog=0.01,fog=0.02", "0.5%", True, [0.01]):  # true: a TOML typo
        with pytest.raises(SettingsError, match="target_noise"):
            ReferenceSettings(target_noise=bad)
    out = tmp_path / "r.exr"
    args = ["reference", "refocus", "--width", "32", "--height", "32", "--photons", str(1 << 16), "--spp", "16",
            "--batches", "4", "-o", str(out)]
    assert main([*args, "--target-noise", "caustic=0.02,fog=0.01"]) == 0
    printed = capsys.readouterr().out
    assert "stopped by target" in printed and "noise floor caustic" in printed
    manifest = json.loads((tmp_path / "r.json").read_text())
    assert manifest["noise_floor"]["caustic"] <= 0.02 and manifest["target_noise"] == {"caustic": 0.02, "fog": 0.01}
    assert main([*args, "--target-noise", "fog=lots"]) == 2
    assert "target_noise fog" in capsys.readouterr().err
