"""The built-in catalogue: seven scenes, paper triangle counts, closed meshes,
and the geometric property each Figure 5 scene exists for."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from volcaustics.reports.cli import main
from volcaustics.scenes import BUILTIN_NAMES, load_builtin
from volcaustics.scenes.catalogue import builtin_path
from volcaustics.scenes.mesh import closedness_problem, winding_number

# Paper Table 1 / Figure 5 triangle counts of the specular objects; the issue allows 5%.
TARGET_TRIANGLES = {"sphere1": 40_000, "sphere2": 20_000, "bunny": 10_000, "feline": 150_000, "skull": 10_000}


def test_seven_scenes_in_paper_order():
    assert BUILTIN_NAMES == ("sphere1", "sphere2", "bunny", "feline", "skull", "two_spheres", "refocus")
    assert all(load_builtin(name).name == name for name in BUILTIN_NAMES)  # a file's stem is its scene's name


def test_the_media_scenes_are_named_but_not_built_ins():
    """fogbank and smoke resolve by name like a built-in (a command's SCENE, a budgets file's
    key) and are heterogeneous; the report's default, the gate's and the sweeps' every built-in
    leaves them out (their own report: make report-media); an unknown name lists both kinds."""
    from volcaustics.scenes import SceneError, resolve_scene
    from volcaustics.scenes.catalogue import MEDIA_NAMES, is_scene_path, named_path

    assert MEDIA_NAMES == ("fogbank", "smoke")
    assert not set(MEDIA_NAMES) & set(BUILTIN_NAMES)
    for name in MEDIA_NAMES:
        scene = resolve_scene(name)
        assert scene.name == name and scene.medium.is_heterogeneous
        assert not is_scene_path(name) and named_path(name).endswith(f"{name}.toml")
    assert not any(load_builtin(name).medium.is_heterogeneous for name in BUILTIN_NAMES)
    with pytest.raises(SceneError, match="fogbank, smoke"):
        resolve_scene("fog_bank")


def test_the_catalogue_is_the_folder_in_its_files_order(tmp_path):
    """A file dropped in the folder is a scene of the catalogue, placed by its ``order``
    (files without one last, by name); two files of one order are refused naming both."""
    from volcaustics.scenes import SceneError
    from volcaustics.scenes.catalogue import catalogue

    for name, order in (("b", 2), ("a", None), ("c", 1), ("z", None)):
        (tmp_path / f"{name}.toml").write_text("" if order is None else f"order = {order}\n")
    (tmp_path / "notes.txt").write_text("order = 0\n")
    assert catalogue(str(tmp_path)) == ("c", "b", "a", "z")
    (tmp_path / "d.toml").write_text("order = 2\n")
    with pytest.raises(SceneError, match=r"order.*the place of b\.toml already"):
        catalogue(str(tmp_path))


def test_an_order_that_is_not_a_small_integer_is_refused(tmp_path):
    from volcaustics.scenes import SceneError, load_scene

    text = open(builtin_path("refocus")).read().replace("order = 7", 'order = "seventh"')
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(SceneError, match="order.*expected an integer"):
        load_scene(str(tmp_path / "s.toml"))


@pytest.mark.parametrize("name", list(TARGET_TRIANGLES))
def test_triangle_counts_within_5_percent(name):
    count = load_builtin(name).specular_triangle_count()
    assert abs(count - TARGET_TRIANGLES[name]) <= 0.05 * TARGET_TRIANGLES[name], count


@pytest.mark.parametrize("name", BUILTIN_NAMES)
def test_specular_meshes_closed_outward_and_camera_sees_them(name):
    scene = load_builtin(name)
    assert scene.specular and scene.diffuse and not scene.medium.is_vacuum
    cam = scene.camera
    forward = cam.forward
    for obj in scene.specular:
        mesh = obj.mesh.load()
        assert closedness_problem(mesh) is None, obj.name
        assert mesh.signed_volume() > 0, f"{obj.name} is wound inward"
        centre = mesh.vertices.mean(axis=0)
        assert winding_number(mesh, cam.position) < 0.5
        # The object's centre lies inside the camera's vertical field of view.
        to_centre = centre - np.asarray(cam.position)
        angle = math.degrees(math.acos(np.dot(to_centre, forward) / np.linalg.norm(to_centre)))
        assert angle < cam.fov_y / 2, f"{obj.name} is outside the view ({angle:.1f} deg)"
        # ...and inside the light's cutoff cone, close to the light (beams visible in fog).
        to_obj = centre - np.asarray(scene.light.position)
        light_angle = math.degrees(math.acos(np.dot(to_obj, scene.light.direction) / np.linalg.norm(to_obj)))
        assert light_angle < scene.light.cutoff_angle
        assert np.linalg.norm(to_obj) < 3.0


@pytest.mark.parametrize("name", ["feline", "skull"])
def test_standins_say_so(name):
    assert "STAND-IN" in load_builtin(name).description


def _rays_from_light_hit(mesh, origin, targets) -> np.ndarray:
    """For each target point: does the segment origin→target cross ``mesh``? (Möller–Trumbore, numpy)."""
    tri = mesh.vertices[mesh.faces]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    hits = np.zeros(len(targets), dtype=bool)
    for k, target in enumerate(targets):
        d = target - origin
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = origin - tri[:, 0]
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hits[k] = np.any(ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < 1))
    return hits


def test_two_spheres_green_sphere_hidden_from_light():
    scene = load_builtin("two_spheres")
    clear, green = (o.mesh.load() for o in scene.specular)
    assert scene.specular[1].absorption[1] < min(scene.specular[1].absorption[0], scene.specular[1].absorption[2])
    assert scene.specular[0].absorption == (0.0, 0.0, 0.0)
    # Every vertex of the green sphere: the straight path from the light crosses the clear sphere first.
    rng = np.random.default_rng(0)
    sample = green.vertices[rng.choice(len(green.vertices), 300, replace=False)]
    assert _rays_from_light_hit(clear, np.asarray(scene.light.position), sample).all()


def test_refocus_focus_lies_between_sphere_and_floor():
    """Paraxial ball lens (thick lens, principal planes at the centre):
    f = n R / (2 (n - 1)); image distance s' = 1 / (1/f - 1/s) from the centre."""
    scene = load_builtin("refocus")
    obj = scene.specular[0]
    mesh = obj.mesh.load()
    lo, hi = mesh.bounds()
    radius, centre_y = (hi[1] - lo[1]) / 2, (hi[1] + lo[1]) / 2
    f = obj.ior * radius / (2 * (obj.ior - 1))
    s = scene.light.position[1] - centre_y
    focus_y = centre_y - 1.0 / (1.0 / f - 1.0 / s)
    assert 0.0 < focus_y < lo[1] - 0.2  # a visible reconverging cone below the sphere, above the floor


def test_cli_lists_every_builtin(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    for name in BUILTIN_NAMES:
        assert f"\n{name} " in out


def test_bunny_attribution_vendored():
    from volcaustics import scenes

    folder = os.path.join(os.path.dirname(scenes.__file__), "assets")
    text = open(os.path.join(folder, "ATTRIBUTION.md")).read()
    assert "Stanford" in text and os.path.exists(os.path.join(folder, "bunny10k.ply"))
