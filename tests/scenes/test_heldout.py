"""The held-out scenes: they load, differ in character from the built-ins (a
self-occluding knot, a lens array over a thin plate, a dense forward-scattering medium,
a wavy water surface, an upright coil),
and no search spec names them (what a search tunes on cannot be where it is judged)."""

from __future__ import annotations

import glob
import os

import numpy as np

from volcaustics.scenes import resolve_scene
from volcaustics.scenes.catalogue import BUILTIN_NAMES, HELDOUT_NAMES, heldout_path


def _side(u, w, p):
    """Which side of each edge u → w the point p lies on (2-D cross product)."""
    return (w[:, 0] - u[:, 0]) * (p[1] - u[:, 1]) - (w[:, 1] - u[:, 1]) * (p[0] - u[:, 0])


def _crossings(scene, name: str) -> int:
    """The most surfaces of ``name`` a vertical ray meets, over a grid of rays."""
    (obj,) = [o for o in scene.specular if o.name == name]
    mesh = obj.mesh.load()
    v = mesh.vertices[mesh.faces]  # F×3×3, object space: vertical rays along y
    xs = np.linspace(v[..., 0].min(), v[..., 0].max(), 41)
    zs = np.linspace(v[..., 2].min(), v[..., 2].max(), 41)
    best = 0
    a, b, c = v[:, 0, [0, 2]], v[:, 1, [0, 2]], v[:, 2, [0, 2]]
    for x in xs:
        for z in zs:
            p = np.array([x, z])
            s1, s2, s3 = _side(a, b, p), _side(b, c, p), _side(c, a, p)
            inside = ((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))
            best = max(best, int(inside.sum()))
    return best


def test_heldout_scenes_load_with_their_character():
    scenes = {name: resolve_scene(heldout_path(name)) for name in HELDOUT_NAMES}
    assert _crossings(scenes["knot"], "knot") >= 6  # the tube over itself: many layers
    assert len(scenes["lens_array"].specular) == 10
    plate = [o for o in scenes["lens_array"].specular if o.name == "plate"][0].mesh.load().vertices
    centred = plate - plate.mean(axis=0)
    thinnest = np.linalg.svd(centred, full_matrices=False)[2][-1]  # the plate's normal, however it is tilted
    assert np.ptp(centred @ thinnest) <= 0.031  # a thin plate, 3 cm
    medium = scenes["dense_forward"].medium
    assert medium.phase.kind == "hg" and medium.phase.g >= 0.7 and min(medium.sigma_s) >= 0.5
    assert _crossings(scenes["coil"], "coil") >= 10  # two surfaces a turn, five turns
    surface = [o for o in scenes["water"].specular if o.name == "water"][0].mesh.load().vertices
    top = surface[surface[:, 1] > surface[:, 1].min() + 1e-6, 1]  # the top: every vertex off the flat bottom
    assert 0.03 <= np.ptp(top) <= 0.045  # waves of ±2 cm peak (the top's range), not a flat slab
    layered = scenes["layered_fog"].medium.density  # a slab of two densities: the box field
    assert layered is not None and layered.field == "box"
    assert not set(HELDOUT_NAMES) & set(BUILTIN_NAMES)


def test_no_search_names_a_heldout_scene():
    specs = glob.glob(os.path.join(os.path.dirname(heldout_path("knot")), "..", "..", "reports", "**", "*.toml"),
                      recursive=True)
    assert specs
    for path in specs:
        text = open(path, encoding="utf-8").read()  # as text: any key may name scenes
        for name in HELDOUT_NAMES:
            assert name not in text, f"{path} names the held-out scene {name}"
