"""A scene sent to a machine that shares no disk: its mesh files travel as bytes and
are found in that machine's cache; the scene there is the same scene."""

from __future__ import annotations

import pickle
import shutil

import pytest

from volcaustics.infra.errors import InputError
from volcaustics.scenes import load_builtin, load_scene
from volcaustics.scenes.catalogue import builtin_path
from volcaustics.scenes.portable import packed, unpacked


def _scene_here(folder):
    """bunny with its mesh file in ``folder``, loaded from there."""
    original = load_builtin("bunny")
    shutil.copy(original.specular[0].mesh.path, folder / "b.ply")
    text = open(builtin_path("bunny")).read().replace("../assets/bunny10k.ply", "b.ply")
    (folder / "scene.toml").write_text(text)
    return original, load_scene(str(folder / "scene.toml"))


def test_a_packed_scene_is_the_same_scene_where_its_files_are_not(tmp_path, monkeypatch):
    (tmp_path / "here").mkdir()
    original, scene = _scene_here(tmp_path / "here")
    package = pickle.dumps(packed(scene))  # what crosses the network
    shutil.rmtree(tmp_path / "here")  # the other machine has none of this machine's files
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path / "there"))
    there = unpacked(pickle.loads(package))
    assert there.scene_hash() == scene.scene_hash() == original.scene_hash()
    assert there.specular[0].mesh.path.startswith(str(tmp_path / "there"))
    assert len(there.specular[0].mesh.load().faces) == len(original.specular[0].mesh.load().faces)
    assert unpacked(pickle.loads(package)).specular[0].mesh.path == there.specular[0].mesh.path  # written once


def test_a_mesh_file_changed_since_loading_is_refused(tmp_path):
    """Negative control: the bytes sent must be the ones the scene's hash names."""
    _, scene = _scene_here(tmp_path)
    with open(tmp_path / "b.ply", "ab") as fh:
        fh.write(b"\n")
    with pytest.raises(InputError, match="changed since the scene"):
        packed(scene)
