"""V7: the reference's higher scattering orders (mode ``orders``) against estimators that
share none of its code: Mitsuba's ``volpath`` with max_depth K + 1 (camera paths, next
event estimation, BSDF sampling) on scenes where the two count the same paths.

* fog: spot and medium alone (volpath reaches the spot by next-event estimation);
* caustic: a glass sphere lit by a disk area light instead of the spot, no diffuse
  surfaces: volpath reaches the light through the glass by BSDF sampling (noisy but
  unbiased; a small lamp gives it fireflies a z-test cannot judge), so light → glass →
  medium^n → camera paths of every order are compared;
* direct: the surface connection of mode ``orders`` at order 0 against the camera
  integrator's direct light (the higher orders reach surfaces by the continuation the
  first two tests check).

Each comparison is a per-pixel z-test (Šidák, Student's t) with the image totals within
3 standard errors (test_validation.agree), and has a negative control: volpath with
one order fewer must fail it."""

from __future__ import annotations

import numpy as np
import pytest

from tests.reference.agreement import Batches, agree
from tests.shared import make_scene, sphere_spec
from volcaustics.reference.mi_setup import mitsuba
from volcaustics.reference.render.camera_integrator import SingleScatterIntegrator
from volcaustics.reference.render.export import to_mitsuba
from volcaustics.reference.render.integrators import VolumetricLightTracer, configure
from volcaustics.scenes.model import Camera

pytestmark = pytest.mark.slow  # statistical validations: a minute or two

mi = mitsuba()
W = H = 32
K = 3  # orders compared: enough that order 3 is resolved (the negative control drops it)
ALL_ORDERS = 64  # as good as all of them: order 64 carries nothing measurable (asserted)


def _orders(scene, mi_scene, max_scatter=K):
    props = mi.Properties()
    props["mode"] = "orders"
    props["max_scatter"] = max_scatter
    return configure(VolumetricLightTracer(props), scene, mi_scene)


def _stats(images, keep=None) -> Batches:
    """Batches (mean, variance of the mean, per-batch totals) of a stack of batch images,
    over the pixels ``keep`` (the others zero)."""
    images = np.stack(images).astype(np.float64)
    if keep is not None:
        images = np.where(keep[None, ..., None], images, 0.0)
    out = Batches((images.mean(0), images.var(0, ddof=1) / len(images)))
    out.totals = images.sum(axis=(1, 2))
    return out


def _volpath(mi_scene, max_depth, spp, batches, seed0) -> list:
    volpath = mi.load_dict({"type": "volpath", "max_depth": max_depth, "hide_emitters": True})
    return [np.asarray(mi.render(mi_scene, integrator=volpath, seed=seed0 + b, spp=spp))[..., :3]
            for b in range(batches)]


def _ordered(mi_scene, tracer, spp, batches, seed0=0) -> tuple:
    """(whole images, order stacks [component, order, H, W, 3]) of each batch."""
    images, stacks = [], []
    for b in range(batches):
        tracer.prepare_orders(W, H)
        images.append(np.asarray(mi.render(mi_scene, integrator=tracer, seed=seed0 + b, spp=spp))[..., :3])
        stacks.append(tracer.order_images())
    return images, stacks


def _open_scene(**kw):
    """Spot and medium in a box 2 × 2.5 × 3.5 m (light and camera at opposite corners)."""
    cam = Camera(position=(-1.0, 0.5, 4.0), target=(0.3, 1.5, 0.5), fov_y=50.0, width=W, height=H)
    return make_scene([], light_pos=(1.0, 3.0, 0.5), light_dir=(-0.3, -1.0, 0.2), cutoff=30.0, camera=cam,
                      floor=False, **kw)


def test_fog_orders_match_volpath():
    scene = _open_scene(sigma_s=0.6, sigma_a=0.03)
    mi_scene = mi.load_dict(to_mitsuba(scene))
    images, stacks = _ordered(mi_scene, _orders(scene, mi_scene), 256, 8)
    ours = _stats(images)
    assert agree(_stats(_volpath(mi_scene, K + 1, 1024, 8, 100)), ours)
    # every order's image is fog here, and they add up to the whole image (to float32 atomic
    # splat order: 1.6e-4 of the maximum measured; docs/decisions.md "Float32 atomic splats")
    assert np.allclose(sum(s[1].sum(0) for s in stacks) / len(stacks), ours[0], rtol=0, atol=1e-3 * ours[0].max())
    third = np.mean([s[1, K].sum() for s in stacks]) / np.mean([s[1].sum() for s in stacks])
    print("V7 fog: order", K, "share", third)
    # negative control: volpath with one order fewer
    assert not agree(_stats(_volpath(mi_scene, K, 1024, 8, 200)), ours)


def _area_light_scene():
    """A glass sphere (IOR 1.5) under a disk area light facing down, so that most light
    in the medium has crossed the glass; medium (a box 10 m wide), no diffuse surface.
    Mitsuba scene and our scene model (for the tracer's configuration)."""
    cam = Camera(position=(0.0, 1.0, 3.2), target=(0.0, 0.9, 0.0), fov_y=45.0, width=W, height=H)
    # the model's spot above the lamp and its floor (not rendered) only make the medium box
    # (scenes.bounds) hold the lamp and the caustic below the sphere
    scene = make_scene([(sphere_spec(0.5, (0.0, 1.3, 0.0), 16), 1.5, (0.0, 0.0, 0.0))], camera=cam,
                       light_pos=(0.0, 2.6, 0.0), sigma_s=0.5, sigma_a=0.02)
    d = to_mitsuba(scene)
    del d["light"], d["diffuse_0"]
    # a disk lamp facing down just above the sphere: most of its light crosses the glass
    d["lamp"] = {"type": "disk", "to_world": mi.ScalarTransform4f().translate([0.0, 1.85, 0.0]).scale(0.35)
                 @ mi.ScalarTransform4f().rotate([1.0, 0.0, 0.0], 90.0),
                 "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [4.0, 4.0, 4.0]}}}
    return scene, mi.load_dict(d)


def test_caustic_orders_match_volpath_through_glass():
    """volpath's max_depth counts refractions too, so both count every order here (K =
    ALL_ORDERS against no depth limit, Russian roulette from depth 5): the higher orders of
    light that crossed the glass are compared whole, and cutting them at 2 must fail."""
    scene, mi_scene = _area_light_scene()
    keep = ~_seen_glass(scene, mi_scene)
    images, stacks = _ordered(mi_scene, _orders(scene, mi_scene, ALL_ORDERS), 256, 8)
    ours = _stats(images, keep)
    theirs = _stats(_volpath(mi_scene, -1, 4096, 8, 100), keep)
    assert agree(theirs, ours)
    caustic = np.mean([s[0, 2:][:, keep].sum() for s in stacks])
    print("V7 caustic: orders >= 2 of the caustic", caustic, "of all", ours[0].sum(), "volpath", theirs[0].sum())
    assert caustic > 0.2 * ours[0].sum()  # the test is about refracted light's higher orders
    assert np.mean([s[:, ALL_ORDERS][:, keep].sum() for s in stacks]) < 1e-6 * ours[0].sum()  # all orders: none left
    assert not agree(theirs, _stats([s[:, :3].sum(axis=(0, 1)) for s in stacks], keep))  # orders ≤ 2 only


def _seen_glass(scene, mi_scene) -> np.ndarray:
    """Pixels whose camera ray hits the glass (the mask: neither renderer models them alike)."""
    camera = configure(SingleScatterIntegrator(), scene, mi_scene)
    return np.asarray(mi.render(mi_scene, integrator=camera, seed=0, spp=16))[..., 9] > 0.0


def test_direct_order_zero_matches_camera_direct():
    scene = make_scene([(sphere_spec(0.35, (0.0, 1.5, 0.0), 12), 1.5, (0, 0, 0))], cutoff=25.0, sigma_s=0.3,
                       sigma_a=0.05, width=W, height=H)
    mi_scene = mi.load_dict(to_mitsuba(scene))
    _, stacks = _ordered(mi_scene, _orders(scene, mi_scene), 128, 8)
    camera = configure(SingleScatterIntegrator(), scene, mi_scene)
    theirs = _stats([np.asarray(mi.render(mi_scene, integrator=camera, seed=100 + b, spp=32))[..., 6:9]
                     for b in range(8)])
    assert agree(theirs, _stats([s[2, 0] for s in stacks]))
    # negative control: order 0 and order 1 together (light scattered once before the floor too)
    assert not agree(theirs, _stats([s[2, 0] + s[2, 1] for s in stacks]))
