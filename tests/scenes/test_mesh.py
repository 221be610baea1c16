"""Mesh primitives: closedness detection, winding numbers, file formats, generators."""

from __future__ import annotations

import math

import numpy as np
import pytest

from volcaustics.scenes.generators import quad, skull_standin, sphere
from volcaustics.scenes.mesh import Mesh, closedness_problem, read_mesh_file, winding_number
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
