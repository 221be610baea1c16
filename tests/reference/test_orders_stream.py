"""A reference with K > 1 scattering orders: its third stream, the model
term's layers and floors, the noise target over them, the cache key with K, the
single-scattering layers unchanged, and a damaged entry refused."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from volcaustics.reference import cache
from volcaustics.reference.render import render_reference
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.scenes import load_builtin
from volcaustics.scenes.formats import MODEL_LAYERS

BASE = ReferenceSettings(photons=1 << 16, spp=16, batches=4, width=32, height=32, target_noise=None)


def test_k_orders_add_the_model_layers_and_keep_the_single_scattering_ones(empty_cache):
    scene = load_builtin("refocus")
    single = render_reference(scene, BASE, progress=False)
    multiple = render_reference(scene, dataclasses.replace(BASE, max_scatter=3), progress=False)
    assert multiple.key != single.key  # K is in the key
    assert not set(MODEL_LAYERS) & set(single.mean)
    assert set(MODEL_LAYERS) <= set(multiple.mean) and set(MODEL_LAYERS) <= set(multiple.var)
    # the paper's model is the same render, batch for batch (same seeds); the caustic's
    # float32 atomic splats may add in another order (docs/decisions.md "Float32 atomic splats")
    for name in ("fog", "direct", "mask_specular"):
        assert np.array_equal(single.mean[name], multiple.mean[name])
    assert np.allclose(single.mean["caustic"], multiple.mean["caustic"], rtol=1e-5, atol=1e-9)
    # what the orders add is light: non-negative, and present in every component
    for name in MODEL_LAYERS:
        assert (multiple.mean[name] >= 0).all() and multiple.mean[name].sum() > 0, name
    combined = sum(multiple.mean[f"{c}_ms"] for c in ("caustic", "fog", "direct"))
    assert np.allclose(multiple.mean["combined_ms"], combined, rtol=1e-5, atol=1e-9)
    m = multiple.manifest
    assert m["max_scatter"] == 3 and m["orders_batches"] == 4
    assert {f"{c}_ms" for c in ("caustic", "fog", "direct")} <= set(m["noise_floor"])
    for component in ("caustic", "fog", "direct"):
        rule = m["convergence"][component]
        assert len(rule["order_relmse"]) == (2 if component != "direct" else 3)  # orders 2..3; direct 1..3
        assert rule["orders_needed"] in (None, 0, 1, 2)


def test_the_noise_target_covers_the_model_term(empty_cache):
    scene = load_builtin("refocus")
    loose = render_reference(scene, dataclasses.replace(BASE, max_scatter=2), progress=False)
    target = loose.manifest["noise_floor"]["fog_ms"] / 3
    tight = render_reference(scene, dataclasses.replace(BASE, max_scatter=2, target_noise={"fog_ms": target}),
                             progress=False)
    m = tight.manifest
    assert tight.key == loose.key  # the target is a budget, not part of the key: the entry was continued
    assert m["stopped_by"] == "target" and m["noise_floor"]["fog_ms"] <= target
    assert m["orders_batches"] > 4 and m["batches"] == 4 and m["camera_batches"] == 4  # only that stream grew


def test_an_entry_without_its_model_layers_is_not_served(empty_cache):
    scene = load_builtin("refocus")
    settings = dataclasses.replace(BASE, max_scatter=2)
    first = render_reference(scene, settings, progress=False)
    from volcaustics.infra.imageio import read_exr, write_exr

    path = cache.entry_file(first.key, first.manifest, "exr")
    layers, header = read_exr(path)
    write_exr(path, {k: v for k, v in layers.items() if not k.startswith("fog_ms")},
              {k: v for k, v in header.items() if k.startswith("volcaustics")})
    manifest_path = cache.manifest_path(first.key)
    manifest = json.loads(open(manifest_path).read())
    manifest["exr_sha256"] = cache.file_sha256(path)  # hashes made to match: only the layers are wrong
    manifest[cache.SEAL] = cache.document_sha256(manifest, cache.SEAL)
    open(manifest_path, "w").write(json.dumps(manifest))
    assert cache.load(first.key) is None
    again = render_reference(scene, settings, progress=False)
    assert not again.manifest["cached"] and set(MODEL_LAYERS) <= set(again.mean)


def test_mode_orders_is_the_streams_own():
    from volcaustics.reference.mi_setup import mitsuba
    from volcaustics.reference.render.export import to_mitsuba
    from volcaustics.reference.render.integrators import VolumetricLightTracer, configure
    from volcaustics.reference.settings import SettingsError, check_mode

    with pytest.raises(SettingsError, match="max_scatter > 1"):
        check_mode("orders")
    mi = mitsuba()
    scene = load_builtin("refocus")
    mi_scene = mi.load_dict(to_mitsuba(dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, width=8, height=8))))
    props = mi.Properties()
    props["mode"], props["max_scatter"] = "orders", 2
    tracer = configure(VolumetricLightTracer(props), scene, mi_scene)
    with pytest.raises(RuntimeError) as info:  # without its block, a clear error, not a crash
        mi.render(mi_scene, integrator=tracer, spp=1)
    assert "prepare_orders" in str(info.getrepr(chain=True))  # Dr.Jit's loop wraps the cause
