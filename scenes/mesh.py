"""Triangle meshes: reading PLY/OBJ, closedness checks, inside tests.

A :class:`Mesh` holds world-space vertices (V×3 float64, metres) and faces
(F×3 int64, counter-clockwise seen from outside for closed meshes).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.infra.errors import InputError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class MeshReadError(InputError):
    """A mesh file is missing, unreadable or malformed (message says which)."""


@dataclass(frozen=True, eq=False)
class Mesh:
    vertices: np.ndarray  # V×3 float64, metres
    faces: np.ndarray  # F×3 int64, indices into vertices

    @property
    def triangle_count(self) -> int:
        return int(len(self.faces))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(min, max) corners of the axis-aligned bounding box, each (3,) float64 (read-only)."""
        corners = self._kept("_bounds", lambda: np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)]))
        return corners[0], corners[1]

    def signed_volume(self) -> float:
        """Signed enclosed volume (m³); positive when faces wind outward (closed meshes only)."""
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    def transformed(self, matrix: np.ndarray) -> "Mesh":
        """The mesh under a 4×4 affine matrix (winding flipped if it mirrors)."""
        v = self.vertices @ matrix[:3, :3].T + matrix[:3, 3]
        f = self.faces if np.linalg.det(matrix[:3, :3]) >= 0 else self.faces[:, ::-1]
        return Mesh(v, np.ascontiguousarray(f))

    def face_normals(self) -> np.ndarray:
        """Unit geometric normals, F×3 float64 (read-only): (v1 − v0) × (v2 − v0), outward for
        an outward-wound closed mesh (as Mitsuba computes ``si.n``)."""
        return self._kept("_face_normals", self._face_normals)

    def vertex_normals(self) -> np.ndarray:
        """Unit vertex normals, V×3 float64 (read-only): face normals weighted by the corner
        angle (Thürrner & Wüthrich 1998), the shading normals both renderers use."""
        return self._kept("_vertex_normals", self._vertex_normals)

    def _kept(self, name: str, compute) -> np.ndarray:
        """``compute()`` once per mesh, kept read-only: a loaded mesh is shared (``load_mesh_spec``
        caches it), and every renderer and export of it took its normals again (2.4 of 70 s of tests)."""
        kept = self.__dict__.get(name)
        if kept is None:
            kept = compute()
            kept.flags.writeable = False
            object.__setattr__(self, name, kept)
        return kept

    def _face_normals(self) -> np.ndarray:
        tri = self.vertices[self.faces]
        face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        return face_n / np.maximum(np.linalg.norm(face_n, axis=1, keepdims=True), 1e-300)

    def _vertex_normals(self) -> np.ndarray:
        tri = self.vertices[self.faces]
        face_n = self.face_normals()
        normals = np.zeros_like(self.vertices)
        for k in range(3):
            e1 = tri[:, (k + 1) % 3] - tri[:, k]
            e2 = tri[:, (k + 2) % 3] - tri[:, k]
            cos = np.einsum("ij,ij->i", e1, e2) / np.maximum(
                np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300)
            np.add.at(normals, self.faces[:, k], face_n * np.arccos(np.clip(cos, -1, 1))[:, None])
        return normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)

    def flipped(self) -> "Mesh":
        return Mesh(self.vertices, np.ascontiguousarray(self.faces[:, ::-1]))


def without_degenerate_faces(mesh: Mesh) -> Mesh:
    """Drop faces that repeat a vertex index (they carry no area and break edge pairing)."""
    f = mesh.faces
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])
    return Mesh(mesh.vertices, f[keep])


def closedness_problem(mesh: Mesh) -> str | None:
    """Why the mesh is not a closed, consistently oriented 2-manifold, or None if it is.

    Closed (watertight) here means: every directed edge (a→b) occurs exactly once
    and its reverse (b→a) occurs exactly once, i.e. every edge has exactly two
    faces and they agree on orientation.
    """
    f = mesh.faces
    if len(f) == 0:
        return "it has no faces"
    n = np.int64(len(mesh.vertices))
    a = np.concatenate([f[:, 0], f[:, 1], f[:, 2]]).astype(np.int64)
    b = np.concatenate([f[:, 1], f[:, 2], f[:, 0]]).astype(np.int64)
    directed = a * n + b
    uniq, counts = np.unique(directed, return_counts=True)
    if np.any(counts > 1):
        return (f"{int(np.sum(counts > 1))} edges are used twice in the same direction "
                "(non-manifold or inconsistently oriented faces)")
    reverse = b * n + a
    missing = ~np.isin(reverse, uniq)
    if np.any(missing):
        return f"{int(missing.sum())} edges have only one face (holes in the surface)"
    return None


def within_box(mesh: Mesh, point: ArrayLike) -> bool:
    """Whether ``point`` lies within ``mesh``'s bounding box: outside it a closed mesh's
    :func:`winding_number` is 0, so a check of every animation frame's camera and light
    sums the triangles only for points within (refocus's 48 took its whole load, 0.16 s; sphere1's two
    took 0.01 s of its 0.013 s)."""
    p = np.asarray(point, dtype=np.float64)
    lo, hi = mesh.bounds()
    return bool(np.all(p >= lo) and np.all(p <= hi))


def winding_number(mesh: Mesh, point: ArrayLike) -> float:
    """Generalised winding number of a closed mesh around ``point`` (≈1 inside, ≈0 outside).

    Sum of signed solid angles of the triangles (Van Oosterom & Strackee 1983) over 4π.
    """
    p = np.asarray(point, dtype=np.float64)
    a, b, c = (mesh.vertices[mesh.faces[:, k]] - p for k in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc
           + np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb)
    return float(np.sum(2.0 * np.arctan2(det, den)) / (4.0 * np.pi))


# --- file formats -------------------------------------------------------------

def read_mesh_file(path: str) -> Mesh:
    """Read a PLY (ascii or binary) or Wavefront OBJ triangle/polygon mesh.

    Polygons are fan-triangulated. Raises :class:`MeshReadError` with the reason.
    """
    if not os.path.exists(path):
        raise MeshReadError("file does not exist")
    if not os.path.isfile(path) or not os.access(path, os.R_OK):
        raise MeshReadError("file is not readable")
    ext = os.path.splitext(path)[1].lower()
    try:
        if ext == ".ply":
            vertices, polygons = _read_ply(path)
        elif ext == ".obj":
            vertices, polygons = _read_obj(path)
        else:
            raise MeshReadError(f"unsupported extension {ext!r} (use .ply or .obj)")
    except MeshReadError:
        raise
    except Exception as exc:  # any parser failure is a malformed file
        raise MeshReadError(f"cannot parse ({type(exc).__name__}: {exc})") from None
    faces = _triangulate(polygons, len(vertices))
    if not np.all(np.isfinite(vertices)):
        raise MeshReadError("vertex coordinates are not all finite")
    return Mesh(vertices, faces)


def _read_ply(path: str):
    from plyfile import PlyData

    ply = PlyData.read(path)
    names = [e.name for e in ply.elements]
    if "vertex" not in names or "face" not in names:
        raise MeshReadError("PLY needs 'vertex' and 'face' elements")
    vert = ply["vertex"].data
    vertices = np.stack([np.asarray(vert[k], dtype=np.float64) for k in ("x", "y", "z")], axis=1)
    face = ply["face"].data
    key = "vertex_indices" if "vertex_indices" in face.dtype.names else "vertex_index"
    return vertices, [np.asarray(p, dtype=np.int64) for p in face[key]]


def _read_obj(path: str):
    vertices, polygons = [], []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for _lineno, line in enumerate(fh, 1):
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                vertices.append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                idx = []
                for tok in parts[1:]:
                    i = int(tok.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(vertices) + i)
                polygons.append(np.asarray(idx, dtype=np.int64))
    return np.asarray(vertices, dtype=np.float64).reshape(-1, 3), polygons


def _triangulate(polygons, n_vertices: int) -> np.ndarray:
    tris = []
    for p in polygons:
        if len(p) < 3:
            raise MeshReadError("a face has fewer than 3 vertices")
        for k in range(1, len(p) - 1):
            tris.append((p[0], p[k], p[k + 1]))
    faces = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    if len(faces) and (faces.min() < 0 or faces.max() >= n_vertices):
        raise MeshReadError("a face index is out of range")
    return faces


# --- specs -> meshes -------------------------------------------------------------
