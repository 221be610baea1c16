"""Mesh primitives: closedness detection, winding numbers, file formats, generators."""

from __future__ import annotations

import math

import numpy as np
import pytest

from volcaustics.scenes.generators import quad, skull_standin, sphere
from volcaustics.scenes.mesh import Mesh, closedness_problem, read_mesh_file, winding_number, within_box
from volcaustics.scenes.model import Transform


@pytest.mark.parametrize("n", [1, 2, 5, 13])
def test_geodesic_sphere_counts_and_radius(n):
    m = sphere(radius=2.0, subdivisions=n)
    assert m.triangle_count == 20 * n * n
    assert len(m.vertices) == 10 * n * n + 2  # Euler: V - E + F = 2 with E = 3F/2
    assert np.allclose(np.linalg.norm(m.vertices, axis=1), 2.0)
    assert closedness_problem(m) is None
    # Inscribed polyhedron volume approaches 4/3 pi r^3 from below.
    assert 0 < m.signed_volume() < 4 / 3 * math.pi * 8


def test_closedness_detects_holes_and_flipped_faces():
    m = sphere(subdivisions=3)
    assert "only one face" in closedness_problem(Mesh(m.vertices, m.faces[1:]))
    flipped = m.faces.copy()
    flipped[0] = flipped[0, ::-1]
    assert "same direction" in closedness_problem(Mesh(m.vertices, flipped))
    assert closedness_problem(quad()) is not None


def test_winding_number_inside_outside():
    m = sphere(subdivisions=4)
    assert winding_number(m, (0.1, -0.2, 0.3)) == pytest.approx(1.0, abs=1e-9)
    assert winding_number(m, (1.5, 0, 0)) == pytest.approx(0.0, abs=1e-9)
    assert winding_number(m.flipped(), (0, 0, 0)) == pytest.approx(-1.0, abs=1e-9)


def test_only_points_within_the_box_can_be_inside():
    """The animation check's shortcut (``within_box``) passes every point the winding number
    calls inside, and refuses only points whose winding number is 0: a box corner of a sphere
    is within the box and outside the sphere; a point past a face of the box is outside both."""
    m = sphere(subdivisions=4)
    rng = np.random.default_rng(7)
    for p in rng.uniform(-1.3, 1.3, size=(400, 3)):
        if winding_number(m, p) > 0.5:
            assert within_box(m, p)
        if not within_box(m, p):
            assert winding_number(m, p) == pytest.approx(0.0, abs=1e-9)
    assert within_box(m, (0.95, 0.95, 0.95)) and winding_number(m, (0.95, 0.95, 0.95)) < 0.5
    assert not within_box(m, (1.01, 0.0, 0.0))


def test_skull_standin_is_nested_shell():
    """A vertical ray through the shell's side (missing every opening) crosses 4 surfaces."""
    m = skull_standin()
    # Count crossings of the line x = 0.18, z = 0 along y with all triangles (2-D point-in-triangle in xz).
    tri = m.vertices[m.faces][:, :, [0, 2]]
    p = np.array([0.18, 0.0])
    d = tri - p

    def cross2(a, b):
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    c0, c1, c2 = cross2(d[:, 0], d[:, 1]), cross2(d[:, 1], d[:, 2]), cross2(d[:, 2], d[:, 0])
    inside = ((c0 > 0) & (c1 > 0) & (c2 > 0)) | ((c0 < 0) & (c1 < 0) & (c2 < 0))
    assert inside.sum() == 4


def test_transform_order_scale_rotate_translate():
    t = Transform(translate=(1, 2, 3), rotate=(0, 90, 0), scale=2)
    p = t.matrix() @ np.array([1.0, 0.0, 0.0, 1.0])
    assert np.allclose(p[:3], [1, 2, 1])  # (1,0,0)*2 -> rotate +90 about y -> (0,0,-2) -> +t


def test_obj_and_ply_readers_agree(tmp_path):
    from plyfile import PlyData, PlyElement

    m = sphere(subdivisions=2)
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in m.vertices]
    lines += [f"f {a + 1}/1 {b + 1}/1 {c + 1}/1" for a, b, c in m.faces]
    (tmp_path / "s.obj").write_text("\n".join(lines) + "\n")
    vert = np.array([tuple(v) for v in m.vertices], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    face = np.array([(list(f),) for f in m.faces], dtype=[("vertex_indices", "i4", (3,))])
    PlyData([PlyElement.describe(vert, "vertex"), PlyElement.describe(face, "face")]).write(str(tmp_path / "s.ply"))
    a, b = read_mesh_file(str(tmp_path / "s.obj")), read_mesh_file(str(tmp_path / "s.ply"))
    assert np.array_equal(a.faces, b.faces) and np.allclose(a.vertices, b.vertices)
    assert np.array_equal(a.faces, m.faces)


def test_obj_quads_are_triangulated(tmp_path):
    (tmp_path / "q.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    assert read_mesh_file(str(tmp_path / "q.obj")).triangle_count == 2


BIG_SPHERE = (("radius", 1.0), ("subdivisions", 51))  # 52,020 triangles: above the size that is cached on disk


def _save_mesh(path, vertices, faces):
    with open(path, "wb") as fh:
        np.savez(fh, vertices=vertices, faces=faces)


@pytest.mark.parametrize("damage", ["truncated", "garbage", "another mesh", "nan vertex", "face out of range",
                                    "faces missing", "flat vertices"])
def test_a_damaged_generated_mesh_cache_is_regenerated(tmp_path, monkeypatch, damage):
    """A generated-mesh cache file that is truncated, garbage, another generator's mesh
    or not a valid mesh is regenerated and rewritten (before: a truncated file raised,
    reported as a bad scene file on every run; the others were used as the mesh)."""
    from volcaustics.scenes.mesh_cache import generated_mesh

    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path))
    good = generated_mesh("sphere", BIG_SPHERE)
    [path] = (tmp_path / "meshes").glob("*.npz")
    data = path.read_bytes()
    other = sphere(radius=2.0, subdivisions=51)
    if damage == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        path.write_bytes(b"PK\x03\x04" + b"\xff" * 64)
    elif damage == "another mesh":
        _save_mesh(path, other.vertices, other.faces)
    elif damage == "nan vertex":
        vertices = good.vertices.copy()
        vertices[5, 1] = np.nan
        _save_mesh(path, vertices, good.faces)
    elif damage == "face out of range":
        faces = good.faces.copy()
        faces[7, 2] = len(good.vertices)
        _save_mesh(path, good.vertices, faces)
    elif damage == "faces missing":
        with open(path, "wb") as fh:
            np.savez(fh, vertices=good.vertices)
    else:
        _save_mesh(path, good.vertices[:, :2], good.faces)
    again = generated_mesh("sphere", BIG_SPHERE)
    assert np.array_equal(again.vertices, good.vertices) and np.array_equal(again.faces, good.faces)
    with np.load(path) as saved:  # rewritten, so the next run reads it
        assert np.array_equal(saved["vertices"], good.vertices) and np.array_equal(saved["faces"], good.faces)


def test_a_folder_in_place_of_a_generated_mesh_cache_entry_is_not_the_scenes_fault(tmp_path, monkeypatch, capsys):
    """A folder where a generated mesh's cache file goes: the mesh is built (and not
    cached, said once), where before the scene file was blamed ("mesh could not be
    built", hostile pass)."""
    from volcaustics.scenes.mesh_cache import generated_mesh

    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path))
    good = generated_mesh("sphere", BIG_SPHERE)
    [path] = (tmp_path / "meshes").glob("*.npz")
    path.unlink()
    path.mkdir()
    again = generated_mesh("sphere", BIG_SPHERE)
    np.testing.assert_array_equal(again.vertices, good.vertices)
    assert path.is_dir() and "generated meshes" in capsys.readouterr().err
