"""experiment.exact_store: the decomposition's exact images do not depend on how
the approximation searched, are stored under their own key and read back bit for bit;
what they do depend on gives another key; a damaged entry is computed again."""

from __future__ import annotations

import dataclasses
import glob
import os

import numpy as np
import pytest

from tests.shared import make_scene, sphere_spec
from volcaustics.approx import ApproxParams, Renderer
from volcaustics.experiment.exact_store import EXACT_IMAGES
from volcaustics.experiment.measurement import MeasurementSettings
from volcaustics.experiment.pipeline import run_experiment
from volcaustics.reference.oracle import Oracle
from volcaustics.reference.render import render_reference
from volcaustics.reference.settings import ReferenceSettings

PARAMS = ApproxParams(photon_res=48, light_res=128, width=32, height=32, splat_radius=0.03, steps=3, seed=5)
# every parameter the table marks exact=False, changed at once
SEARCHED_OTHERWISE = dict(layers=2, layer_strategy="peel", iterations=8, peak_samples=4, search="dda",
                          start_rule="id", crossing="surface", light_res=64, fog_steps=16)


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VOLCAUSTICS_CACHE", str(tmp_path_factory.mktemp("exact-store-cache")))
        scene = make_scene([(sphere_spec(0.4, (0, 1.5, 0), 16), 1.5, (0.2, 0.0, 0.0))], cutoff=20.0, width=32,
                           height=32, sigma_s=0.3)
        reference = render_reference(scene, ReferenceSettings(photons=1 << 14, spp=4, batches=2, width=32,
                                                              height=32, max_scatter=1))
        renderer, oracle = Renderer(scene), Oracle(scene)

        def measure(params, subphotons=2):
            return run_experiment(scene, params, seeds=2, reference=reference, renderer=renderer, oracle=oracle,
                                  measurement=MeasurementSettings(exact_subphotons=subphotons, scope="decomposition"))

        yield scene, measure
        renderer.release()


def _exact_images(result) -> dict:
    return {name: result.layers[name] for name in result.layers if not name.startswith("term.")}


def _stored():
    return sorted(glob.glob(os.path.join(os.environ["VOLCAUSTICS_CACHE"], "exact-images", "*.npz")))


def test_exact_images_reused_across_the_search_bit_for_bit(setup, monkeypatch):
    """A point that searches otherwise reads the first point's E images (one entry, reused);
    its decomposition is the one it gets with the E images computed afresh; and computed
    afresh they are the same arrays (they do not depend on the search)."""
    scene, measure = setup
    first = measure(PARAMS)
    assert not first.summary["exact"]["images_reused"] and len(_stored()) == 1
    other = dataclasses.replace(PARAMS, **SEARCHED_OTHERWISE)
    reused = measure(other)
    assert reused.summary["exact"]["images_reused"] and len(_stored()) == 1
    assert reused.summary["exact"]["images_key"] == first.summary["exact"]["images_key"]
    monkeypatch.setattr("volcaustics.experiment.exact_images.load_exact", lambda key, document: None)
    fresh = measure(other)
    assert not fresh.summary["exact"]["images_reused"]
    for name, image in _exact_images(fresh).items():
        assert np.array_equal(image, _exact_images(reused)[name]), name
    assert reused.summary["decomposition"]["rows"] == fresh.summary["decomposition"]["rows"]
    # negative control: A itself differs between the two searches (else the test shows nothing)
    assert not np.array_equal(reused.layers["approx"], first.layers["approx"])


@pytest.mark.parametrize("change", [{"steps": 2}, {"fresnel": "stochastic"}, {"photon_res": 40},
                                    {"splat_radius": 0.02}, {"seed": 6}, {"emission": "adaptive"}])
def test_what_the_exact_images_depend_on_gives_another_key(setup, change):
    scene, measure = setup
    base = measure(PARAMS).summary["exact"]
    other = measure(dataclasses.replace(PARAMS, **change)).summary["exact"]
    assert not other["images_reused"] and other["images_key"] != base["images_key"]


def test_other_subphotons_and_adaptive_splats_give_another_key(setup):
    scene, measure = setup
    base = measure(PARAMS).summary["exact"]["images_key"]
    assert measure(PARAMS, subphotons=3).summary["exact"]["images_key"] != base
    adaptive = dataclasses.replace(PARAMS, splat="adaptive")
    key = measure(adaptive).summary["exact"]["images_key"]  # A's kernels: every parameter is in the key
    assert measure(dataclasses.replace(adaptive, iterations=8)).summary["exact"]["images_key"] != key


def test_a_damaged_entry_is_computed_again(setup):
    scene, measure = setup
    good = measure(PARAMS)
    path = os.path.join(os.environ["VOLCAUSTICS_CACHE"], "exact-images", good.summary["exact"]["images_key"] + ".npz")
    data = bytearray(open(path, "rb").read())
    data[len(data) // 2] ^= 0xFF
    open(path, "wb").write(bytes(data))
    again = measure(PARAMS)
    assert not again.summary["exact"]["images_reused"]
    for name in EXACT_IMAGES:
        assert np.array_equal(again.layers[name], good.layers[name]), name
