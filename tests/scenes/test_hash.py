"""scene_hash: stable across runs, machines and file locations; changes with every physical parameter."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import subprocess
import sys

from volcaustics.scenes import load_builtin, load_scene
from volcaustics.scenes.model import Medium, Phase, Transform

# Frozen once: the canonical-JSON format is a cache key, so an accidental change to
# it (or to float formatting on another machine) must fail here. Update only on
# purpose, together with scenes.model.FORMAT.
REFOCUS_HASH = "a00068a4c437"


def test_builtin_hash_is_frozen():
    assert load_builtin("refocus").scene_hash()[:12] == REFOCUS_HASH


def test_hash_same_in_fresh_process_with_other_hash_seed():
    here = load_builtin("bunny").scene_hash()
    code = "from volcaustics.scenes import load_builtin; print(load_builtin('bunny').scene_hash())"
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.stdout.strip() == here


def test_moving_scene_and_mesh_files_keeps_hash(tmp_path):
    """File meshes enter the hash by content, not location; labels do not enter."""
    from volcaustics.scenes.catalogue import builtin_path

    original = load_builtin("bunny")
    (tmp_path / "assets").mkdir()
    shutil.copy(original.specular[0].mesh.path, tmp_path / "assets" / "b.ply")
    text = open(builtin_path("bunny")).read().replace("../assets/bunny10k.ply", "assets/b.ply")
    text = text.replace('name = "bunny"', 'name = "renamed"', 1)
    (tmp_path / "moved.toml").write_text(text)
    moved = load_scene(str(tmp_path / "moved.toml"))
    assert moved.name == "renamed"
    assert moved.scene_hash() == original.scene_hash()
    assert str(tmp_path) not in moved.canonical_json()


def test_mesh_file_content_changes_hash(tmp_path):
    """One vertex moved by 1 µm in the PLY file changes the hash."""
    from plyfile import PlyData

    from volcaustics.scenes.catalogue import builtin_path

    original = load_builtin("bunny")
    ply = PlyData.read(original.specular[0].mesh.path)
    ply["vertex"].data["x"][0] += 1e-6
    ply.write(str(tmp_path / "b.ply"))
    text = open(builtin_path("bunny")).read().replace("../assets/bunny10k.ply", "b.ply")
    (tmp_path / "s.toml").write_text(text)
    assert load_scene(str(tmp_path / "s.toml")).scene_hash() != original.scene_hash()


def _variants(scene):
    """One copy of the scene per physical parameter, each with that parameter changed."""
    r = dataclasses.replace
    cam, light, med, obj, flo = scene.camera, scene.light, scene.medium, scene.specular[0], scene.diffuse[0]
    spec = obj.mesh
    yield "camera.position", r(scene, camera=r(cam, position=(0.0, 1.2, 4.6)))
    yield "camera.target", r(scene, camera=r(cam, target=(0.0, 1.1, 0.0)))
    yield "camera.up", r(scene, camera=r(cam, up=(0.1, 0.995, 0.0)))
    yield "camera.fov_y", r(scene, camera=r(cam, fov_y=cam.fov_y + 1e-9))
    yield "camera.width", r(scene, camera=r(cam, width=cam.width + 1))
    yield "camera.height", r(scene, camera=r(cam, height=cam.height + 1))
    yield "light.position", r(scene, light=r(light, position=(0.0, 3.01, 0.0)))
    yield "light.direction", r(scene, light=r(light, direction=(0.0, -0.9999, 0.01414)))
    yield "light.intensity", r(scene, light=r(light, intensity=(10.0, 10.0, 10.5)))
    yield "light.cutoff_angle", r(scene, light=r(light, cutoff_angle=17.0))
    yield "light.beam_width", r(scene, light=r(light, beam_width=13.0))
    yield "medium.sigma_s", r(scene, medium=r(med, sigma_s=(0.2, 0.2, 0.21)))
    yield "medium.sigma_a", r(scene, medium=r(med, sigma_a=(0.03, 0.02, 0.02)))
    yield "medium.g", r(scene, medium=r(med, phase=Phase("hg", 0.3)))
    yield "specular.ior", r(scene, specular=(r(obj, ior=1.51),))
    yield "specular.absorption", r(scene, specular=(r(obj, absorption=(0.0, 0.1, 0.0)),))
    yield "specular.mesh.params", r(scene, specular=(
        r(obj, mesh=r(spec, params=(("radius", 0.41), ("subdivisions", 32)))),))
    yield "specular.mesh.translate", r(scene, specular=(
        r(obj, mesh=r(spec, transform=Transform(translate=(0, 1.41, 0)))),))
    yield "specular.mesh.rotate", r(scene, specular=(
        r(obj, mesh=r(spec, transform=r(spec.transform, rotate=(0, 1, 0)))),))
    yield "specular.mesh.scale", r(scene, specular=(r(obj, mesh=r(spec, transform=r(spec.transform, scale=1.01))),))
    yield "specular.count", r(scene, specular=(obj, obj))
    yield "diffuse.albedo", r(scene, diffuse=(r(flo, albedo=(0.6, 0.6, 0.61)),))
    yield "vacuum", r(scene, medium=Medium())


def test_every_physical_parameter_changes_hash():
    scene = load_builtin("refocus")
    base = scene.scene_hash()
    seen = {base}
    for label, variant in _variants(scene):
        h = variant.scene_hash()
        assert h != base, f"changing {label} did not change scene_hash"
        seen.add(h)
    assert len(seen) == 1 + len(list(_variants(scene)))  # all distinct


def test_labels_do_not_change_hash():
    scene = load_builtin("refocus")
    relabelled = dataclasses.replace(scene, name="x", description="y", source="/elsewhere/z.toml",
                                     specular=(dataclasses.replace(scene.specular[0], name="other"),))
    assert relabelled.scene_hash() == scene.scene_hash()


def test_canonical_json_is_sorted_and_compact():
    text = load_builtin("two_spheres").canonical_json()
    data = json.loads(text)
    assert json.dumps(data, sort_keys=True, separators=(",", ":")) == text
    assert data["specular"][1]["absorption"] == [4.0, 0.2, 4.0]
