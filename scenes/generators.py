"""Procedural meshes for the built-in catalogue and for user scenes.

Each generator takes keyword parameters (validated against :data:`GENERATORS`)
and returns a :class:`scenes.mesh.Mesh` in object space, y up, centred near the
origin. Closed generators return closed, outward-wound meshes.

* ``sphere``: geodesic sphere (icosahedron, each face split into
  ``subdivisions``² triangles): 20·subdivisions² triangles.
* ``shell``: a hollow sphere, outer surface outward, inner surface inward.
* ``quad``: a ``size_x`` × ``size_z`` rectangle in the plane y = 0, facing +y (open).
* ``feline_standin``: stand-in for the paper's Feline (150k triangles): a
  cat-like body (genus 4) with a tail loop, two crossing ring wings and four legs, so that rays from above
  cross many surfaces. Marching cubes of a smooth implicit surface.
* ``skull_standin``: stand-in for the paper's Skull (10k triangles): a hollow
  closed shell (outer and inner surface nested) with eye, nose, top and
  foramen openings. Marching cubes of an implicit surface.
* ``knot``, ``coil``: a tube swept along a torus knot or an upright helix (marching
  cubes of the distance to the curve): rays along the axis meet many surfaces.
* ``plate``: a thin plate with rounded edges.
* ``water``: a slab whose top is a seeded sum of sine waves (a heightfield; flat bottom
  and sides): a refracting surface that focuses light into a network of caustics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .mesh import Mesh, closedness_problem, without_degenerate_faces

GENERATOR_VERSION = 1  # bump when a generator's output changes for the same parameters (in the scene hash)


@dataclass(frozen=True)
class ParamSpec:
    kind: type  # int or float
    default: float
    low: float
    high: float
    doc: str


@dataclass(frozen=True)
class Generator:
    func: Callable[..., Mesh]
    params: dict
    closed: bool
    doc: str


# --- sphere ----------------------------------------------------------------------

def _icosahedron():
    t = (1.0 + 5.0**0.5) / 2.0
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
                  [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=np.float64)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                  [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                  [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    return v / np.linalg.norm(v, axis=1, keepdims=True), f


def sphere(radius: float = 1.0, subdivisions: int = 8) -> Mesh:
    """Geodesic sphere of ``radius`` with 20·subdivisions² triangles."""
    n = int(subdivisions)
    base_v, base_f = _icosahedron()
    # Barycentric lattice of one face: points (i, j) with i + j <= n.
    ij = np.array([(i, j) for i in range(n + 1) for j in range(n + 1 - i)], dtype=np.int64)
    index = {(i, j): k for k, (i, j) in enumerate(ij)}
    lattice: list[tuple[int, int, int]] = []
    for i in range(n):
        for j in range(n - i):
            lattice.append((index[i, j], index[i + 1, j], index[i, j + 1]))
            if i + j < n - 1:
                lattice.append((index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]))
    tris = np.asarray(lattice, dtype=np.int64)
    w1, w2 = ij[:, 0:1] / n, ij[:, 1:2] / n
    point_sets: list[np.ndarray] = []
    face_sets: list[np.ndarray] = []
    for f in base_f:
        a, b, c = base_v[f]
        p = a + w1 * (b - a) + w2 * (c - a)
        face_sets.append(tris + len(point_sets) * len(ij))
        point_sets.append(p / np.linalg.norm(p, axis=1, keepdims=True))
    points = np.concatenate(point_sets)
    faces = np.concatenate(face_sets)
    # Weld the lattice points shared along icosahedron edges.
    keys = np.round(points * 1e9).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    mesh = Mesh(points[first] * radius, inverse.reshape(-1)[faces])
    return _outward(mesh)


def shell(radius: float = 1.0, inner_radius: float = 0.8, subdivisions: int = 8) -> Mesh:
    """Hollow sphere: outer surface wound outward, inner surface wound inward (towards
    the cavity), one closed mesh of 40·subdivisions² triangles."""
    if not 0 < inner_radius < radius:
        raise ValueError(f"inner_radius {inner_radius} must lie in (0, radius = {radius})")
    outer = sphere(radius, subdivisions)
    inner = sphere(inner_radius, subdivisions).flipped()
    return Mesh(np.concatenate([outer.vertices, inner.vertices]),
                np.concatenate([outer.faces, inner.faces + len(outer.vertices)]))


def quad(size_x: float = 1.0, size_z: float = 1.0) -> Mesh:
    """Rectangle in y = 0, centred at the origin, facing +y (2 triangles, open)."""
    hx, hz = size_x / 2.0, size_z / 2.0
    v = np.array([[-hx, 0, -hz], [hx, 0, -hz], [hx, 0, hz], [-hx, 0, hz]], dtype=np.float64)
    f = np.array([[0, 2, 1], [0, 3, 2]], dtype=np.int64)
    return Mesh(v, f)


# --- implicit surfaces ---------------------------------------------------------------

def _smooth_union(a, b, k):
    """Polynomial smooth minimum of two distance fields (blend width k)."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b * (1 - h) + a * h - k * h * (1 - h)


def _sd_torus(p, center, axis, major, minor):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    q = p - np.asarray(center, float)
    along = q @ axis
    radial = np.linalg.norm(q - along[..., None] * axis, axis=-1)
    return np.hypot(radial - major, along) - minor


def _sd_capsule(p, a, b, r):
    a, b = np.asarray(a, float), np.asarray(b, float)
    pa, ba = p - a, b - a
    h = np.clip((pa @ ba) / (ba @ ba), 0.0, 1.0)
    return np.linalg.norm(pa - h[..., None] * ba, axis=-1) - r


def _sd_sphere(p, center, r):
    return np.linalg.norm(p - np.asarray(center, float), axis=-1) - r


def _mesh_from_field(field, lo, hi, resolution: int) -> Mesh:
    """Closed mesh of the zero level set of ``field`` sampled on a grid over [lo, hi]."""
    from skimage.measure import marching_cubes

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    step = (hi - lo).max() / resolution
    counts = np.ceil((hi - lo) / step).astype(int) + 3  # one padding cell each side
    axes = [lo[k] - step + step * np.arange(counts[k]) for k in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    values = field(grid)
    values[[0, -1], :, :] = values[:, [0, -1], :] = values[:, :, [0, -1]] = 1.0  # seal
    verts, faces, _, _ = marching_cubes(values, level=0.0, spacing=(step, step, step))
    mesh = Mesh(verts.astype(np.float64) + (lo - step), faces.astype(np.int64))
    return _outward(without_degenerate_faces(mesh))


def _outward(mesh: Mesh) -> Mesh:
    return mesh.flipped() if mesh.signed_volume() < 0 else mesh


def feline_standin(resolution: int = 220) -> Mesh:
    """Cat-like closed body of genus 4 about 1.0 × 0.9 × 0.5 m: torso, head, four
    legs, a tail loop and two ring 'wings' standing upright, so that vertical rays
    from a light above cross up to ten surfaces."""

    def field(p):
        d = _sd_capsule(p, (-0.28, 0.0, 0.0), (0.26, 0.02, 0.0), 0.13)  # torso
        d = _smooth_union(d, _sd_sphere(p, (0.40, 0.14, 0.0), 0.11), 0.06)  # head
        for x in (-0.22, 0.20):
            for z in (-0.08, 0.08):
                d = _smooth_union(d, _sd_capsule(p, (x, -0.02, z), (x + 0.02, -0.40, z), 0.045), 0.04)  # legs
        d = _smooth_union(d, _sd_torus(p, (-0.46, 0.12, 0.0), (0, 0, 1), 0.14, 0.035), 0.04)  # tail loop
        for z, tilt in ((-0.07, -0.35), (0.07, 0.35)):
            d = _smooth_union(d, _sd_torus(p, (0.0, 0.24, z), (0.0, tilt, 1.0), 0.17, 0.04), 0.04)  # wings
        return d

    return _mesh_from_field(field, (-0.66, -0.46, -0.34), (0.56, 0.52, 0.34), resolution)


def skull_standin(resolution: int = 31) -> Mesh:
    """Hollow closed shell about 0.5 m across: outer and inner ellipsoidal surfaces
    (walls 0.05 m) joined at two eye sockets, a nose opening, a top opening and a
    foramen underneath, so rays cross nested outer/inner surfaces."""

    def field(p):
        q = p / np.array([0.25, 0.24, 0.28])
        r = np.linalg.norm(q, axis=-1) * 0.25  # ellipsoidal radius, ~metres
        shell = np.maximum(r - 0.25, 0.20 - r)
        holes = np.minimum.reduce([
            _sd_capsule(p, (-0.08, 0.02, 0.1), (-0.08, 0.02, 0.4), 0.05),  # eyes
            _sd_capsule(p, (0.08, 0.02, 0.1), (0.08, 0.02, 0.4), 0.05),
            _sd_capsule(p, (0.0, -0.09, 0.1), (0.0, -0.09, 0.4), 0.03),  # nose
            _sd_capsule(p, (0.0, 0.1, -0.02), (0.0, 0.4, -0.02), 0.06),  # top
            _sd_capsule(p, (0.0, -0.4, -0.08), (0.0, -0.1, -0.08), 0.06),  # foramen
        ])
        return np.maximum(shell, -holes)

    return _mesh_from_field(field, (-0.28, -0.27, -0.31), (0.28, 0.27, 0.31), resolution)


def knot(radius: float = 0.35, tube: float = 0.06, p: int = 2, q: int = 3, resolution: int = 96) -> Mesh:
    """A (p, q) torus-knot tube (2, 3: the trefoil) about 2·(radius + tube) across: the
    curve r(t) = radius·(1 + ½cos qt)·(cos pt, ½ sin qt, sin pt) swept by a tube; it
    crosses over itself, so rays from above meet up to eight surfaces."""
    t = np.linspace(0.0, 2.0 * np.pi, 4000, endpoint=False)
    ring = radius * (1.0 + 0.5 * np.cos(q * t))
    curve = np.stack([ring * np.cos(p * t), 0.5 * radius * np.sin(q * t), ring * np.sin(p * t)], axis=1)
    extent = 1.5 * radius + tube
    return _tube_along(curve, tube, (-extent, -0.5 * radius - tube, -extent), (extent, 0.5 * radius + tube, extent),
                       resolution)


def _tube_along(curve: np.ndarray, tube: float, lo, hi, resolution: int) -> Mesh:
    """Closed mesh of the points within ``tube`` of the polyline ``curve`` (K×3)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(curve)

    def field(points):
        distance, _ = tree.query(points.reshape(-1, 3))
        return distance.reshape(points.shape[:-1]) - tube

    return _mesh_from_field(field, lo, hi, resolution)


def coil(radius: float = 0.25, tube: float = 0.045, pitch: float = 0.13, turns: float = 5.0,
         resolution: int = 80) -> Mesh:
    """An upright helix tube (a spring) of ``turns`` turns about the y axis, centred at the
    origin: a ray along the axis through the tube's ring meets two surfaces per turn."""
    t = np.linspace(0.0, 2.0 * np.pi * turns, int(800 * turns))
    height = pitch * turns
    curve = np.stack([radius * np.cos(t), pitch * t / (2.0 * np.pi) - height / 2.0, radius * np.sin(t)], axis=1)
    reach = radius + tube
    return _tube_along(curve, tube, (-reach, -height / 2.0 - tube, -reach), (reach, height / 2.0 + tube, reach),
                       resolution)


def water(size_x: float = 1.6, size_z: float = 1.6, depth: float = 0.06, amplitude: float = 0.006,
          wavelength: float = 0.2, seed: int = 0, resolution: int = 128) -> Mesh:
    """A slab of ``size_x`` × ``size_z`` whose top, ``depth`` above its flat bottom, is a
    sum of five sine waves (wavelengths 0.7–1.3 × ``wavelength``, directions and phases
    drawn from ``seed``) scaled to peak ``amplitude``: a heightfield on a
    ``resolution``² grid, with flat bottom and sides; the bottom at y = 0."""
    if amplitude >= depth:
        raise ValueError(f"amplitude = {amplitude!r} must be below depth = {depth!r} (the waves would cut through "
                         f"the bottom)")
    rng = np.random.default_rng(seed)
    angles = rng.uniform(0.0, np.pi, 5)
    phases = rng.uniform(0.0, 2.0 * np.pi, 5)
    lengths = wavelength * np.array([1.0, 0.8, 1.3, 0.7, 1.1])
    n = resolution
    x = np.linspace(-size_x / 2.0, size_x / 2.0, n + 1)
    z = np.linspace(-size_z / 2.0, size_z / 2.0, n + 1)
    gx, gz = np.meshgrid(x, z, indexing="ij")
    waves = sum(np.sin(2.0 * np.pi / lam * (np.cos(a) * gx + np.sin(a) * gz) + ph)
                for a, ph, lam in zip(angles, phases, lengths))
    heights = depth + amplitude * waves / np.abs(waves).max()
    top = np.stack([gx, heights, gz], axis=-1).reshape(-1, 3)
    bottom = np.stack([gx, np.zeros_like(gx), gz], axis=-1).reshape(-1, 3)
    index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]  # a cell, counter-clockwise in x, z
    cells = np.stack([np.stack([a, c, b], -1), np.stack([a, d, c], -1)], axis=2).reshape(-1, 3)
    ring = np.concatenate([index[:, 0], index[-1, 1:], index[-2::-1, -1], index[0, -2:0:-1]])  # boundary loop
    following = np.roll(ring, -1)
    offset = len(top)
    sides = np.concatenate([np.stack([ring, following, following + offset], -1),
                            np.stack([ring, following + offset, ring + offset], -1)])
    faces = np.concatenate([cells, cells[:, ::-1] + offset, sides])
    return _outward(Mesh(np.concatenate([top, bottom]), faces.astype(np.int64)))


def plate(size_x: float = 0.6, size_z: float = 0.4, thickness: float = 0.04, resolution: int = 150) -> Mesh:
    """A thin plate with rounded edges (a box of the sizes, its edges rounded by half the
    thickness), centred at the origin in y = 0."""
    half = np.array([size_x / 2.0, thickness / 2.0, size_z / 2.0])
    rounding = thickness / 2.0

    def field(points):
        q = np.abs(points) - (half - rounding)
        return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0) - rounding

    return _mesh_from_field(field, -half, half, resolution)


GENERATORS: dict[str, Generator] = {
    "sphere": Generator(sphere, {
        "radius": ParamSpec(float, 1.0, 1e-6, 1e6, "sphere radius (m)"),
        "subdivisions": ParamSpec(int, 8, 1, 200, "geodesic frequency; 20·n² triangles"),
    }, True, "geodesic sphere"),
    "shell": Generator(shell, {
        "radius": ParamSpec(float, 1.0, 1e-6, 1e6, "outer radius (m)"),
        "inner_radius": ParamSpec(float, 0.8, 1e-6, 1e6, "cavity radius (m), < radius"),
        "subdivisions": ParamSpec(int, 8, 1, 200, "geodesic frequency of each surface"),
    }, True, "hollow sphere (two nested surfaces)"),
    "quad": Generator(quad, {
        "size_x": ParamSpec(float, 1.0, 1e-6, 1e6, "extent along x (m)"),
        "size_z": ParamSpec(float, 1.0, 1e-6, 1e6, "extent along z (m)"),
    }, False, "rectangle in y = 0 facing +y"),
    "feline_standin": Generator(feline_standin, {
        "resolution": ParamSpec(int, 220, 8, 400, "marching-cubes cells along the longest side"),
    }, True, "stand-in for the paper's Feline"),
    "knot": Generator(knot, {
        "radius": ParamSpec(float, 0.35, 1e-3, 1e3, "the knot's radius (m)"),
        "tube": ParamSpec(float, 0.06, 1e-4, 1e2, "the tube's radius (m)"),
        "p": ParamSpec(int, 2, 1, 16, "turns around the axis"),
        "q": ParamSpec(int, 3, 1, 16, "turns through the hole"),
        "resolution": ParamSpec(int, 96, 8, 400, "marching-cubes cells along the longest side"),
    }, True, "a torus-knot tube (self-occluding)"),
    "plate": Generator(plate, {
        "size_x": ParamSpec(float, 0.6, 1e-3, 1e3, "extent along x (m)"),
        "size_z": ParamSpec(float, 0.4, 1e-3, 1e3, "extent along z (m)"),
        "thickness": ParamSpec(float, 0.04, 1e-4, 1e2, "thickness along y (m)"),
        "resolution": ParamSpec(int, 150, 8, 400, "marching-cubes cells along the longest side"),
    }, True, "a thin plate with rounded edges"),
    "coil": Generator(coil, {
        "radius": ParamSpec(float, 0.25, 1e-3, 1e3, "the helix's radius (m)"),
        "tube": ParamSpec(float, 0.045, 1e-4, 1e2, "the tube's radius (m)"),
        "pitch": ParamSpec(float, 0.13, 1e-3, 1e3, "rise per turn (m)"),
        "turns": ParamSpec(float, 5.0, 0.1, 100, "turns"),
        "resolution": ParamSpec(int, 80, 8, 400, "marching-cubes cells along the longest side"),
    }, True, "an upright helix tube (many layers along its axis)"),
    "water": Generator(water, {
        "size_x": ParamSpec(float, 1.6, 1e-3, 1e3, "extent along x (m)"),
        "size_z": ParamSpec(float, 1.6, 1e-3, 1e3, "extent along z (m)"),
        "depth": ParamSpec(float, 0.06, 1e-4, 1e2, "mean depth, bottom to surface (m)"),
        "amplitude": ParamSpec(float, 0.006, 0.0, 1e2, "the waves' peak height (m), < depth"),
        "wavelength": ParamSpec(float, 0.2, 1e-3, 1e3, "the waves' mean wavelength (m)"),
        "seed": ParamSpec(int, 0, 0, 2**31 - 1, "seed of the waves' directions and phases"),
        "resolution": ParamSpec(int, 128, 2, 1024, "heightfield cells per side"),
    }, True, "a slab with a wavy top (a caustic network)"),
    "skull_standin": Generator(skull_standin, {
        "resolution": ParamSpec(int, 31, 8, 400, "marching-cubes cells along the longest side"),
    }, True, "stand-in for the paper's Skull"),
}


def generate(name: str, params: dict) -> Mesh:
    """Run generator ``name`` with already-validated ``params``."""
    gen = GENERATORS[name]
    mesh = gen.func(**params)
    if gen.closed:
        problem = closedness_problem(mesh)
        if problem is not None:  # a bug in the generator, not in the user's input
            raise RuntimeError(f"generator {name} produced an open mesh: {problem}")
    return mesh
