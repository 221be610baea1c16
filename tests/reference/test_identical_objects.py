"""Identical glass objects stay apart in the reference: Mitsuba's load-time merging of
objects with the same BSDF and media had made nine identical lenses one shape without
an id, which the light tracer took for nothing, so their caustic vanished (found by the
held-out lens_array). The shape table now refuses a lost object (the negative control:
the merged scene), and two identical spheres' caustic is twice one's."""

from __future__ import annotations

import pytest

from tests.shared import make_scene, sphere_spec
from volcaustics.reference.description import describe
from volcaustics.reference.mi_setup import mitsuba
from volcaustics.reference.render import render_reference
from volcaustics.reference.render.export import load_scene, mitsuba_dict
from volcaustics.reference.render.shapes import ShapeTable
from volcaustics.reference.settings import ReferenceSettings


def _scene(xs):
    return make_scene([(sphere_spec(0.2, (x, 1.5, 0.0), 12), 1.5, (0.0, 0.0, 0.0)) for x in xs], cutoff=30.0,
                      width=32, height=32)


def test_identical_objects_keep_their_shapes_and_a_merged_scene_is_refused():
    mi = mitsuba()
    scene = _scene((-0.4, 0.4))
    description = describe(scene)
    table = ShapeTable(mi, load_scene(mi, description), scene)  # every object found: no error
    assert table is not None
    merged = mi.load_dict(mitsuba_dict(description))  # Mitsuba's default: the two spheres become one shape
    assert "" in [shape.id() for shape in merged.shapes()]
    with pytest.raises(RuntimeError, match="lost or renamed"):
        ShapeTable(mi, merged, scene)


def test_two_identical_spheres_make_twice_one_spheres_caustic(cache):
    """Mirror-placed spheres under a spot on the axis: the pair's caustic energy is twice
    the left one's alone, within 5 SE of the references' batch noise (measured: the
    merged scene gave 0)."""
    settings = ReferenceSettings(photons=1 << 18, spp=8, batches=8, target_noise=None, width=32, height=32)
    pair = render_reference(_scene((-0.4, 0.4)), settings, progress=False)
    one = render_reference(_scene((-0.4,)), settings, progress=False)
    total = pair.mean["caustic"].sum()
    single = one.mean["caustic"].sum()
    se = (pair.var["caustic"].sum() + 4 * one.var["caustic"].sum()) ** 0.5
    assert single > 0 and abs(total - 2 * single) <= 5 * se + 0.05 * total, (total, single, se)
