"""`volcaustics reference` / `export`, and the cache's integrity checks."""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np
import pytest

from volcaustics.infra.imageio import read_exr
from volcaustics.reference import cache
from volcaustics.reference.render import render_reference
from volcaustics.reference.settings import ReferenceSettings, SettingsError
from volcaustics.reports.cli import main
from volcaustics.scenes import load_builtin
from volcaustics.scenes.formats import LAYER_NAMES

SMALL = ["--width", "24", "--height", "24", "--photons", "200000", "--spp", "16", "--batches", "4"]


def test_reference_cli_renders_then_serves_from_cache(tmp_path, empty_cache, capsys):
    out = tmp_path / "r.exr"
    assert main(["reference", "refocus", *SMALL, "-o", str(out)]) == 0
    first = json.loads((tmp_path / "r.json").read_text())
    assert first["cached"] is False and first["batches"] == 4 and first["photons"] >= 200000
    assert first["mitsuba_variant"] == "llvm_ad_rgb" and first["scene_hash"] == load_builtin("refocus").scene_hash()
    layers, header = read_exr(str(out))
    assert set(LAYER_NAMES) | {"caustic_var", "combined_var"} <= set(layers)
    assert layers["caustic"].max() > 0 and np.all(layers["caustic_var"] >= 0)
    assert main(["reference", "refocus", *SMALL, "-o", str(out)]) == 0
    second = json.loads((tmp_path / "r.json").read_text())
    assert second["cached"] is True and "cache" in capsys.readouterr().out
    again, _ = read_exr(str(out))
    assert all(np.array_equal(layers[k], again[k]) for k in layers)


def test_an_entry_continued_by_another_process_while_copied_out_is_served_anew(tmp_path, empty_cache,
                                                                              monkeypatch):
    """Another process continued the entry between the lookup and the copy (its files
    replaced by the continuation's): ``reference -o`` failed with FileNotFoundError on a
    cache file; it now serves the continued entry."""
    import shutil

    import volcaustics.reports.presenting.exports.reference_files as command

    scene = load_builtin("refocus")
    small = ReferenceSettings(photons=100000, spp=8, batches=2, width=16, height=12)
    render_reference(scene, small, progress=False)
    real = shutil.copyfile
    raced = []

    def racing(src, dst):
        if not raced:  # the other process: more batches of the same entry, committed now
            raced.append(render_reference(scene, dataclasses.replace(small, photons=150000, spp=12, batches=3),
                                          progress=False))
        return real(src, dst)

    monkeypatch.setattr(command.shutil, "copyfile", racing)
    summary = command.run_reference(scene, small, str(tmp_path / "r.exr"))
    assert summary["batches"] == 3 and summary["exr_sha256"] == raced[0].manifest["exr_sha256"]


def test_truncated_cache_entry_is_rerendered(empty_cache):
    scene = load_builtin("refocus")
    settings = ReferenceSettings(photons=100000, spp=8, batches=2, width=16, height=16)
    first = render_reference(scene, settings, progress=False)
    exr, manifest = first.exr_path, cache.manifest_path(first.key)
    data = open(exr, "rb").read()
    open(exr, "wb").write(data[: len(data) // 2])  # a crash mid-write elsewhere, or disk trouble
    second = render_reference(scene, settings, progress=False)
    assert not first.cached and not second.cached  # the broken entry was not trusted
    third = render_reference(scene, settings, progress=False)
    assert third.cached
    os.unlink(manifest)  # an EXR without its manifest is not trusted either
    assert not render_reference(scene, settings, progress=False).cached


def test_settings_changes_change_the_key():
    """What one batch is keys an entry; how many batches (or which target) does not:
    an entry is continued batch by batch."""
    scene = load_builtin("refocus")
    a = ReferenceSettings(photons=1 << 20, spp=8, batches=2, width=64, height=64)
    keys = {cache.cache_key(scene, a)}
    for change in ({"photons": 1 << 21}, {"spp": 16}, {"seed": 1}, {"max_scatter": 2}, {"width": 17}):
        keys.add(cache.cache_key(scene, dataclasses.replace(a, **change)))
    assert len(keys) == 6
    same_batch = ({"photons": 1 << 21, "spp": 16, "batches": 4}, {"target_noise": 0.01},
                  {"max_photons": 1 << 22, "max_seconds": 5.0})
    for change in same_batch:
        assert cache.cache_key(scene, dataclasses.replace(a, **change)) == cache.cache_key(scene, a)


def test_bad_settings_exit_2(tmp_path, capsys):
    with pytest.raises(SettingsError):
        ReferenceSettings(batches=1)
    assert main(["reference", "refocus", "--batches", "1", "-o", str(tmp_path / "x.exr")]) == 2
    assert "batches = 1" in capsys.readouterr().err


def test_export_xml_loads_in_mitsuba(tmp_path):
    from volcaustics.reference.mi_setup import mitsuba

    mi = mitsuba()
    out = tmp_path / "two.xml"
    assert main(["export", "two_spheres", "--mitsuba-xml", str(out)]) == 0
    scene = mi.load_file(str(out))
    assert len(scene.shapes()) == 4  # two glass spheres, the floor, the medium box
    image = np.asarray(mi.render(scene, spp=4))
    assert image.shape == (512, 512, 3) and np.isfinite(image).all() and image.mean() > 0
    # the XML declares its size and sample count as <default>s, which a caller overrides
    small = mi.load_file(str(out), resx=32, resy=24, spp=2)
    assert tuple(small.sensors()[0].film().size()) == (32, 24)
    assert small.sensors()[0].sampler().sample_count() == 2
    text = out.read_text()
    assert '<default name="spp" value="16"/>' in text and "cannot render this scene's volume caustic" in text


@pytest.mark.parametrize("existing", [False, True])
def test_an_interrupted_export_leaves_no_mesh_folder_it_made(tmp_path, monkeypatch, existing):
    """Ctrl-C during `export` left an empty OUT_meshes/; a folder that was
    there before stays."""
    from volcaustics.reference.render import export

    meshes = tmp_path / "two_meshes"
    if existing:
        meshes.mkdir()

    def interrupted(*_, **__):
        raise KeyboardInterrupt

    monkeypatch.setattr(export, "to_mitsuba", interrupted)
    with pytest.raises(KeyboardInterrupt):
        export.export_xml(load_builtin("two_spheres"), str(tmp_path / "two.xml"))
    assert meshes.is_dir() == existing and not (tmp_path / "two.xml").exists()


def test_image_size_has_one_place_in_the_key():
    """A scene whose camera was resized and the scene as loaded, with settings naming
    the same size, are the same render: one key (the report used to resize the camera,
    the CLI only the settings, and got two)."""
    scene = load_builtin("refocus")
    settings = ReferenceSettings(photons=100000, spp=8, batches=2, width=24, height=24)
    camera = dataclasses.replace(scene.camera, width=24, height=24)
    resized = dataclasses.replace(scene, camera=camera)
    assert cache.cache_key(resized, settings) == cache.cache_key(scene, settings)
    # settings without a size take the camera's, so the resized scene alone is that render too
    unsized = dataclasses.replace(settings, width=None, height=None)
    assert cache.cache_key(resized, unsized) == cache.cache_key(scene, settings)
    assert cache.cache_key(scene, unsized) != cache.cache_key(scene, settings)  # 512² is another render


def test_a_cache_hit_needs_no_variant_probe(empty_cache, monkeypatch):
    """Without VOLCAUSTICS_MI_VARIANT a cached reference of any preferred variant is
    served (its manifest says which), so a hit never probes variants or imports Mitsuba
    in a fresh process (both cost seconds on a cold machine)."""
    from volcaustics.reference import variant

    scene = load_builtin("refocus")
    settings = ReferenceSettings(photons=100000, spp=8, batches=2, width=16, height=16)
    first = render_reference(scene, settings, progress=False)  # llvm_ad_rgb, from tests/conftest.py
    monkeypatch.delenv("VOLCAUSTICS_MI_VARIANT")

    def no_probe():
        raise AssertionError("probed variants on a cache hit")

    monkeypatch.setattr(variant, "reference_variant", no_probe)
    again = render_reference(scene, settings, progress=False)
    assert again.cached and again.key == first.key and again.manifest["mitsuba_variant"] == "llvm_ad_rgb"
