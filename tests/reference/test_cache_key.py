"""The reference cache key follows what determines the image: the scene as Mitsuba
gets it (medium box, meshes with their normals), the integrator code, the settings,
the mode, the Mitsuba version and variant; and nothing else."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from volcaustics.reference import cache
from volcaustics.reference.render.export import mesh_file
from volcaustics.reference.settings import ReferenceSettings, SettingsError
from volcaustics.scenes import bounds, load_builtin
from volcaustics.scenes.mesh import Mesh

SETTINGS = ReferenceSettings(photons=100000, spp=8, batches=2, width=24, height=24)


def _key(name="refocus", settings=SETTINGS, **kwargs) -> str:
    return cache.cache_key(load_builtin(name), settings, **kwargs)


def test_identical_inputs_give_identical_keys():
    for name in ("refocus", "bunny"):
        assert _key(name) == _key(name)
    assert _key("refocus") != _key("bunny")


def test_key_is_stable_across_processes_and_needs_no_mitsuba():
    """Same key in a fresh process with another hash seed; computing it does not
    import Mitsuba (a cached `volcaustics reference` call stays cheap)."""
    code = ("import sys; from volcaustics.reference import cache; "
            "from volcaustics.reference.settings import ReferenceSettings; "
            "from volcaustics.scenes import load_builtin; "
            "s = ReferenceSettings(photons=100000, spp=8, batches=2, width=24, height=24); "
            "print(cache.cache_key(load_builtin('refocus'), s)); print('mitsuba' in sys.modules)")
    env = {**os.environ, "PYTHONHASHSEED": "4321", "VOLCAUSTICS_MI_VARIANT": "llvm_ad_rgb"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    key, imported = out.stdout.split()
    assert key == _key() and imported == "False"


def test_a_change_of_normals_changes_the_key_and_the_ply_file(monkeypatch, tmp_path):
    """Mitsuba shades with the vertex normals written into the PLY files; they come
    from scenes.mesh, not from the scene description, so the key must see them."""
    mesh = load_builtin("refocus").specular[0].mesh.load()
    before_key, before_file = _key(), mesh_file(mesh, str(tmp_path))
    original = Mesh.vertex_normals

    def tilted(self):
        n = original(self) + np.array([0.0, 1e-3, 0.0])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    monkeypatch.setattr(Mesh, "vertex_normals", tilted)
    assert _key() != before_key
    after_file = mesh_file(mesh, str(tmp_path))
    assert after_file != before_file  # a PLY is named by all it holds, normals included
    assert open(after_file, "rb").read() != open(before_file, "rb").read()


def test_the_medium_box_margin_changes_the_key(monkeypatch):
    before = _key()
    monkeypatch.setattr(bounds, "MARGIN", 2 * bounds.MARGIN)
    assert _key() != before


def test_mode_size_variant_and_versions_change_the_key(monkeypatch):
    base = _key()
    keys = {base, _key(mode="fog"), _key(mode="all"), _key(variant="cuda_ad_rgb"),
            _key(settings=dataclasses.replace(SETTINGS, width=25)),
            _key(settings=dataclasses.replace(SETTINGS, height=25))}
    assert len(keys) == 6
    assert _key(mode="caustic") == base and _key(variant="llvm_ad_rgb") == base  # the defaults here
    from volcaustics.reference import mi_setup

    monkeypatch.setattr(mi_setup, "library_versions", lambda: {"mitsuba": "0.0.1", "drjit": "0.0.1"})
    assert _key() != base
    with pytest.raises(SettingsError, match="mode"):
        _key(mode="caustics")


def test_the_key_document_names_what_determines_the_image():
    """The hashed document itself: the Mitsuba scene with meshes as PLY digests and
    transforms as plain data (no file paths, no Mitsuba objects)."""
    from volcaustics.reference.request import resolve

    request = resolve(load_builtin("refocus"), SETTINGS, "fog")
    doc = cache.key_document(request, "llvm_ad_rgb")
    assert set(doc) >= {"mitsuba_scene", "scene", "settings", "mode", "code", "mitsuba"}
    assert doc["mode"] == "fog" and doc["mitsuba"]["variant"] == "llvm_ad_rgb"
    text = json.dumps(doc, sort_keys=True)
    assert "filename" not in text and ".ply" not in text  # meshes by content, never by where they lie
    film = doc["mitsuba_scene"]["sensor"]["film"]
    assert (film["width"], film["height"]) == (24, 24)
    assert doc["mitsuba_scene"]["specular_0"]["mesh"] in request.description.meshes


def test_versions_read_without_import_match_the_package_metadata():
    from importlib.metadata import version

    from volcaustics.reference import mi_setup

    assert mi_setup.library_versions() == {"mitsuba": version("mitsuba"), "drjit": version("drjit")}


def test_how_far_paths_are_followed_is_in_the_key(monkeypatch):
    """The light tracer's max_path is a constant of ``scenes.formats`` (shared with the
    exact replay's steps), outside the hashed reference/render code: the key names it,
    so a reference traced to fewer segments is never served for more."""
    from volcaustics.reference.request import resolve

    request = resolve(load_builtin("refocus"), SETTINGS, "caustic")
    before = cache.request_key(request, "llvm_ad_rgb")
    monkeypatch.setattr(cache, "PATH_INTERACTIONS", cache.PATH_INTERACTIONS // 8)
    assert cache.request_key(request, "llvm_ad_rgb") != before
