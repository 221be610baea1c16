"""Every malformed-scene case names file, key and value, and the CLI exits 2."""

from __future__ import annotations

import copy
import os
import subprocess
import sys

import pytest
import tomli_w

try:
    import tomllib
except ModuleNotFoundError:
    import tomli as tomllib

from tests.shared import BASE_SCENE
from volcaustics.reports.cli import main
from volcaustics.scenes import SceneError, load_scene


def _set(path, value):
    def mutate(doc):
        node = doc
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
    return mutate


def _delete(path):
    def mutate(doc):
        node = doc
        for k in path[:-1]:
            node = node[k]
        del node[path[-1]]
    return mutate


# (id, mutation, key that must be named, text of the value that must be named)
CASES = [
    ("unknown top-level key", _set(["colour"], 3), "colour", "3"),
    ("unknown camera key", _set(["camera", "fov"], 40), "camera.fov", "40"),
    ("unknown medium key", _set(["medium", "density"], 1.0), "medium.density", "1.0"),
    ("fov wrong type", _set(["camera", "fov_y"], "wide"), "camera.fov_y", "'wide'"),
    ("fov far below float32", _set(["camera", "fov_y"], 1e-30), "camera.fov_y", "1e-30"),  # hung the reference
    ("fov below the minimum", _set(["camera", "fov_y"], 0.05), "camera.fov_y", "0.05"),
    # the centre pixels held the whole scene: approx (a sample per pixel centre) rendered 0, the reference not
    ("fov near 180", _set(["camera", "fov_y"], 179.999), "camera.fov_y", "179.999"),
    ("fov beyond the widest", _set(["camera", "fov_y"], 160.001), "camera.fov_y", "160.001"),
    ("cutoff far below float32", _set(["light", "cutoff_angle"], 1e-30), "light.cutoff_angle", "1e-30"),
    ("beam below the minimum", _set(["light", "beam_width"], 1e-12), "light.beam_width", "1e-12"),
    ("width not integer", _set(["camera", "width"], 64.5), "camera.width", "64.5"),
    ("width boolean", _set(["camera", "width"], True), "camera.width", "True"),
    ("intensity two entries", _set(["light", "intensity"], [1.0, 2.0]), "light.intensity", "[1.0, 2.0]"),
    ("position not list", _set(["camera", "position"], 3.0), "camera.position", "3.0"),
    ("missing light", _delete(["light"]), "light", "None"),
    ("negative sigma_s", _set(["medium", "sigma_s"], -0.1), "medium.sigma_s", "-0.1"),
    ("negative sigma_a entry", _set(["medium", "sigma_a"], [0.1, -2.0, 0.1]), "medium.sigma_a[1]", "-2.0"),
    ("negative absorption", _set(["specular", 0, "absorption"], [-1.0, 0.0, 0.0]), "specular[0].absorption[0]", "-1.0"),
    ("negative intensity", _set(["light", "intensity"], -5.0), "light.intensity", "-5.0"),
    ("ior below one", _set(["specular", 0, "ior"], 0.9), "specular[0].ior", "0.9"),
    # an angle named as an angle: it said "[-1e6, 1e6] m"
    ("rotation out of range", _set(["specular", 0, "transform", "rotate"], [0.0, 2e6, 0.0]),
     "specular[0].transform.rotate[1]", "1000000.0] degrees"),
    ("cutoff zero", _set(["light", "cutoff_angle"], 0.0), "light.cutoff_angle", "0.0"),
    ("cutoff ninety", _set(["light", "cutoff_angle"], 90.0), "light.cutoff_angle", "90.0"),
    ("cutoff beyond the maps", _set(["light", "cutoff_angle"], 89.99), "light.cutoff_angle", "89.99"),
    ("dark light", _set(["light", "intensity"], 0.0), "light.intensity", "0.0"),
    ("cutoff beyond ninety", _set(["light", "cutoff_angle"], 95.0), "light.cutoff_angle", "95.0"),
    ("cutoff negative", _set(["light", "cutoff_angle"], -5.0), "light.cutoff_angle", "-5.0"),
    ("beam wider than cutoff", _set(["light", "beam_width"], 30.0), "light.beam_width", "30.0"),
    ("zero-length direction", _set(["light", "direction"], [0.0, 0.0, 0.0]), "light.direction", "[0.0, 0.0, 0.0]"),
    ("camera inside glass", _set(["camera", "position"], [0.0, 1.1, 0.1]), "camera.position", "[0.0, 1.1, 0.1]"),
    # approx lit the floor from inside the ball (direct sum 768) where the reference has none (0)
    ("light inside glass", _set(["light", "position"], [0.0, 1.1, 0.1]), "light.position", "[0.0, 1.1, 0.1]"),
    ("camera up parallel", _set(["camera", "up"], [0.0, 0.0, 1.0]), "camera.up", "[0.0, 0.0, 1.0]"),
    ("phase unknown", _set(["medium", "phase"], "rayleigh"), "medium.phase", "'rayleigh'"),
    ("hg g out of range", _set(["medium", "g"], 1.0), "medium.g", "1.0"),
    ("g without hg", _set(["medium", "g"], 0.3), "medium.g", "0.3"),
    ("nan coefficient", _set(["medium", "sigma_s"], float("nan")), "medium.sigma_s", "nan"),
    ("albedo above one", _set(["diffuse", 0, "albedo"], 1.5), "diffuse[0].albedo", "1.5"),
    ("unknown generator", _set(["specular", 0, "mesh"], {"generator": "teapot"}), "specular[0].mesh.generator",
     "'teapot'"),
    ("generator param too big", _set(["specular", 0, "mesh", "subdivisions"], 10**6), "specular[0].mesh.subdivisions",
     "1000000"),
    ("missing mesh file", _set(["specular", 0, "mesh"], "nowhere/bunny.ply"), "specular[0].mesh.path",
     "'nowhere/bunny.ply'"),
    ("duplicate names", _set(["diffuse", 0, "name"], "ball"), "diffuse[0].name", "'ball'"),
    # waves deeper than the slab would cut through its bottom (an inverted mesh)
    ("waves deeper than the water", _set(["specular", 0, "mesh"], {"generator": "water", "depth": 0.02,
                                                                   "amplitude": 0.03, "resolution": 8}),
     "specular[0].mesh", "amplitude = 0.03 must be below depth = 0.02"),
]


def _write(tmp_path, doc) -> str:
    path = tmp_path / "broken.toml"
    path.write_bytes(tomli_w.dumps(doc).encode())
    return str(path)


@pytest.mark.parametrize("mutate,key,value", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_malformed_scene_names_file_key_value(tmp_path, capsys, mutate, key, value):
    doc = copy.deepcopy(tomllib.loads(BASE_SCENE))
    mutate(doc)
    path = _write(tmp_path, doc)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    err = info.value
    assert err.file == path and err.key == key
    message = str(err)
    assert path in message and key in message and value in message, message
    assert main(["scenes", "--check", path]) == 2
    stderr = capsys.readouterr().err
    assert key in stderr and value in stderr and "Traceback" not in stderr
    assert len(stderr.strip().splitlines()) <= 2


def test_base_scene_is_valid(write_scene, capsys):
    """The mutations above start from a valid scene (else they would prove nothing)."""
    path = write_scene()
    scene = load_scene(path)
    assert scene.name == "base" and len(scene.specular) == 1
    assert main(["scenes", "--check", path]) == 0
    assert "ok:" in capsys.readouterr().out


def _mesh_scene(write_scene, mesh_ref: str) -> str:
    doc = tomllib.loads(BASE_SCENE)
    doc["specular"][0]["mesh"] = mesh_ref
    return write_scene(tomli_w.dumps(doc))


def test_unreadable_mesh(write_scene, tmp_path):
    (tmp_path / "garbage.ply").write_bytes(b"ply\nthis is not a ply header\x00\xff")
    path = _mesh_scene(write_scene, "garbage.ply")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.key == "specular[0].mesh" and "garbage.ply" in str(info.value)
    assert "readable PLY or OBJ" in str(info.value)


def test_mesh_path_is_a_directory(write_scene, tmp_path):
    (tmp_path / "meshdir.obj").mkdir()
    path = _mesh_scene(write_scene, "meshdir.obj")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.key == "specular[0].mesh.path" and "meshdir.obj" in str(info.value)


def test_non_watertight_specular_mesh(write_scene, tmp_path):
    # A tetrahedron with one face missing: three edges have a single face.
    (tmp_path / "open.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\n")
    path = _mesh_scene(write_scene, "open.obj")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.key == "specular[0].mesh" and "open.obj" in str(info.value)
    assert "watertight" in str(info.value) and "3 edges have only one face" in str(info.value)


def test_closed_obj_mesh_loads(write_scene, tmp_path):
    # The same tetrahedron, closed: loads (the check above is not merely "OBJ fails").
    (tmp_path / "closed.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n")
    path = _mesh_scene(write_scene, "closed.obj")
    assert load_scene(path).specular[0].mesh.load().triangle_count == 4


def test_inward_wound_specular_mesh(write_scene, tmp_path):
    """The closed tetrahedron above with every face reversed was accepted and the
    approximation's caustic came out 147× the reference's: refused when the
    scene is read, naming the file (refused, not flipped: a file that winds inward may hold
    inward normals too, and the scene's author should know)."""
    (tmp_path / "inward.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 2 4 3\n"
                                         "f 1 3 4\n")
    path = _mesh_scene(write_scene, "inward.obj")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.key == "specular[0].mesh" and "inward.obj" in str(info.value)
    assert "wind outward" in str(info.value) and "-0.167 m³" in str(info.value)
    assert main(["scenes", "--check", path]) == 2


def test_invalid_toml_syntax(write_scene):
    path = write_scene("[camera\nposition = [0, 1, 2]\n")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.file == path and "invalid TOML" in str(info.value)


def test_missing_scene_file(tmp_path, capsys):
    path = str(tmp_path / "absent.toml")
    assert main(["scenes", "--check", path]) == 2
    assert "absent.toml" in capsys.readouterr().err


def test_unknown_scene_name_in_cli(capsys):
    assert main(["report", "--scenes", "sphere9"]) == 2
    err = capsys.readouterr().err
    assert "sphere9" in err and "sphere1" in err


def test_console_script_exits_2_without_traceback(write_scene):
    doc = tomllib.loads(BASE_SCENE)
    doc["specular"][0]["ior"] = 0.5
    path = write_scene(tomli_w.dumps(doc))
    exe = os.path.join(os.path.dirname(sys.executable), "volcaustics")
    proc = subprocess.run([exe, "scenes", "--check", path], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "specular[0].ior = 0.5" in proc.stderr and "Traceback" not in proc.stderr


def test_long_value_keeps_its_file_name():
    """A long path was cut at its end, dropping the very file name the message must
    name (seen under pytest-xdist's longer temporary folders): the middle goes instead."""
    path = "/" + "deep/" * 30 + "open.obj"
    text = str(SceneError("scene.toml", "specular[0].mesh", path, "meshes must be closed"))
    assert "open.obj" in text and "..." in text and len(text) < 200
