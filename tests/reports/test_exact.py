"""experiment.exact: subsets, the box filter, and the exact caustic's batches adding up to
the caustic of all photons (the splatter is linear in the photons)."""

from __future__ import annotations

import dataclasses
import json
import math
import os

import numpy as np
import pytest

from tests.shared import make_scene, sphere_spec, write_compared_images
from volcaustics.approx import ApproxParams, Renderer
from volcaustics.experiment.exact import (
    box_downsample,
    exact_caustic,
    exact_photons,
    interleaved_subsets,
    pixel_footprint,
)
from volcaustics.scenes import load_builtin


@pytest.mark.parametrize("batches,shape", [(16, (4, 4)), (8, (2, 4)), (6, (2, 3)), (5, (1, 5))])
def test_interleaved_subsets_tile_the_emission_grid(batches, shape):
    res = 60
    photon = np.arange(res * res)
    subset = interleaved_subsets(photon, res, batches).reshape(res, res)
    a, b = shape
    np.testing.assert_array_equal(subset[:a, :b].ravel(), np.arange(batches))  # one texel of each per a×b tile
    np.testing.assert_array_equal(subset, np.tile(subset[:a, :b], (res // a, res // b)))
    assert np.all(np.bincount(subset.ravel(), minlength=batches) == res * res // batches)


def test_box_downsample_and_pixel_footprint():
    image = np.arange(4 * 6 * 3, dtype=np.float32).reshape(4, 6, 3)
    mean = box_downsample(image, 2)
    assert mean.shape == (2, 3, 3) and mean.dtype == np.float32
    assert mean[0, 0, 0] == pytest.approx(image[:2, :2, 0].mean())
    assert box_downsample(image, 2, np.max)[1, 2, 1] == image[2:, 4:, 1].max()
    assert box_downsample(image, 1) is image
    camera = load_builtin("sphere1").camera  # 4.5 m from its target (and 0.2 m up), fov_y 36°
    distance = math.hypot(4.5, 0.2)
    assert pixel_footprint(camera, 64) == pytest.approx(2 * distance * math.tan(math.radians(18)) / 64)
    assert pixel_footprint(camera, 64, 1.0) == pytest.approx(2 * math.tan(math.radians(18)) / 64)


def test_exact_caustic_batches_add_up_to_all_photons(gl_context):
    scene = make_scene([(sphere_spec(0.4, (0, 1.5, 0), 16), 1.5, (0, 0, 0))], cutoff=20.0, width=32, height=32)
    params = ApproxParams(photon_res=64, light_res=128, width=32, height=32, splat_radius=0.03, seed=3)
    renderer = Renderer(scene)
    try:
        fine = dataclasses.replace(params, width=64, height=64)
        photons = exact_photons(scene, fine, steps=32, fresnel="stochastic", renderer=renderer)
        assert photons.photons > 500 and len(photons.splats) > 100
        assert photons.alive_fraction < 0.05
        assert photons.collided_power.shape == (32, 3) and photons.params["steps"] == 32
        result = exact_caustic(scene, params, steps=32, fresnel="stochastic", batches=4, supersample=2,
                               renderer=renderer, photons=photons)
        whole = box_downsample(renderer.splat(photons.splats, params=fine), 2)
        np.testing.assert_allclose(result.mean, whole, rtol=1e-4, atol=1e-6 * whole.max())
        assert result.batch_images.shape == (4, 32, 32, 3) and result.var.shape == (32, 32, 3)
        assert result.mask_specular.shape == (32, 32, 3) and result.mask_specular.max() == 1.0
        assert result.params["supersample"] == 2 and result.params["batches"] == 4
        total, total_var = result.total(result.mask_specular[..., 0] < 0.5)
        assert np.all(total > 0) and np.all(total_var > 0)
        with pytest.raises(ValueError):
            exact_caustic(scene, params, steps=32, fresnel="stochastic", batches=1, photons=photons,
                          renderer=renderer)
        with pytest.raises(ValueError):
            exact_caustic(scene, params, steps=32, fresnel="stochastic", supersample=0, photons=photons,
                          renderer=renderer)
    finally:
        renderer.release()


def test_failure_images_are_written(tmp_path, monkeypatch):
    monkeypatch.setenv("VOLCAUSTICS_TEST_OUTPUT", str(tmp_path))
    image = np.ones((4, 5, 3), np.float32)
    folder = write_compared_images("tests/x.py::test[a b]", {"test": image, "reference": 2 * image,
                                                              "difference": -image},
                                   info={"ratio": np.array([0.5])}, exposure_from="reference")
    assert folder == os.path.join(str(tmp_path), "tests_x.py_test_a_b")
    assert sorted(os.listdir(folder)) == ["compared.exr", "difference.png", "info.json", "reference.png", "test.png"]
    with open(os.path.join(folder, "info.json"), encoding="utf-8") as fh:
        assert json.load(fh) == {"ratio": [0.5]}


def test_sub_photons_pool_independent_replays_of_the_same_texels(gl_context):
    """The E_∞ images' sub-photons (exact_images.pooled): each replay of the same emission
    grid has its own random numbers (the first A's), their pool keeps the texel indices
    (subsets stay paired) at 1/M of the power, and pooling M copies of one replay is that
    replay's image."""
    from volcaustics.experiment.exact_images import pooled, replay_seed

    assert replay_seed(7, 0) == 7 and len({replay_seed(7, m) for m in range(1, 9)} | {7, 8, 9}) == 11
    scene = make_scene([(sphere_spec(0.4, (0, 1.5, 0), 16), 1.5, (0, 0, 0))], cutoff=20.0, width=32, height=32)
    params = ApproxParams(photon_res=64, light_res=128, width=32, height=32, splat_radius=0.03, seed=3)
    renderer = Renderer(scene)
    try:
        one, two = (exact_photons(scene, dataclasses.replace(params, seed=replay_seed(3, m)), steps=32,
                                  fresnel="stochastic", renderer=renderer) for m in (0, 1))
        assert one.photons == two.photons and max(one.photon.max(), two.photon.max()) < 64 * 64  # one grid ...
        assert not np.array_equal(one.splats["center_status"][:50], two.splats["center_status"][:50])  # other paths
        both = pooled([one, two])
        assert len(both.splats) == len(one.splats) + len(two.splats) and both.params["subphotons"] == 2
        np.testing.assert_allclose(both.splats["power"].sum(axis=0),
                                   (one.splats["power"].sum(axis=0) + two.splats["power"].sum(axis=0)) / 2,
                                   rtol=1e-5)
        twice = renderer.splat(pooled([one, one]).splats, params=params)
        np.testing.assert_allclose(twice, renderer.splat(one.splats, params=params), rtol=1e-4,
                                   atol=1e-6 * twice.max())
    finally:
        renderer.release()
