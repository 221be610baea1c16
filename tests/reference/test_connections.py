"""The light tracer's camera connections.

A medium segment's single scattering toward the eye is ∫ σs·phase·T·W(x(t)) dt with the
sensor importance W ∝ 1/d². One equiangular vertex over the whole segment put all of
its Δθ/D into one pixel, although a segment passing close to the eye draws a long
streak: fireflies. The tracer now clips the segment to the view pyramid and takes n
stratified equiangular vertices (n from its geometric term Δθ/D, at most one per
pixel). These tests check the pieces against brute force and quadrature, that the
estimator is unbiased where the fireflies were (against the camera integrator, an
independent estimator of the same fog), and that it removes them.
"""

from __future__ import annotations

import math

import drjit as dr
import numpy as np
import pytest

from tests.shared import make_scene, sphere_spec
from volcaustics.metrics.stats import z_test
from volcaustics.reference.mi_setup import mitsuba
from volcaustics.reference.render.camera_integrator import SingleScatterIntegrator
from volcaustics.reference.render.export import to_mitsuba
from volcaustics.reference.render.integrators import VolumetricLightTracer, configure
from volcaustics.reference.render.sampling import ViewPyramid, subtended_angle
from volcaustics.scenes.model import Camera

mi = mitsuba()
W = H = 48


class SingleConnection(VolumetricLightTracer):
    """The estimator before stratified connections: one equiangular vertex on the whole segment."""

    def connections(self, view, ray, t_end):
        width = dr.width(t_end)
        return dr.zeros(mi.Float, width), t_end, dr.full(mi.Bool, True, width), dr.full(mi.UInt32, 1, width)


def _near_camera_scene(glass: bool = False):
    """The camera stands in the spot's cone (40°, from 1.8 m above it): the direct beams
    and, with ``glass``, the caustic beams pass within centimetres of the eye."""
    cam = Camera(position=(0.0, 1.2, 2.2), target=(0.0, 0.6, 0.0), fov_y=40.0, width=W, height=H)
    objects = [(sphere_spec(0.3, (0.0, 1.8, 1.2), 12), 1.5, (0, 0, 0))] if glass else []
    return make_scene(objects, camera=cam, light_pos=(0.0, 3.0, 1.2), cutoff=40.0, sigma_s=0.3, sigma_a=0.05)


def _tracer(cls, scene, mi_scene, mode, **props):
    p = mi.Properties()
    p["mode"] = mode
    for key, value in props.items():
        p[key] = value
    return configure(cls(p), scene, mi_scene)


def _batches(mi_scene, integrator, spp, batches, channels, seed0):
    images = np.stack([np.asarray(mi.render(mi_scene, integrator=integrator, seed=seed0 + b, spp=spp))[..., channels]
                       for b in range(batches)]).astype(np.float64)
    return images


def _sensor(width=64, height=48):
    return mi.load_dict({"type": "perspective", "fov": 40.0, "fov_axis": "y", "near_clip": 1e-3,
                         "to_world": mi.ScalarTransform4f().look_at(origin=[0.3, 1.2, 2.5], target=[0.0, 0.8, 0.0],
                                                                    up=[0.0, 1.0, 0.0]),
                         "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}}})


def test_view_pyramid_clip_matches_the_sensor():
    """Every point the sensor sees lies inside [s_in, s_out], and every point inside
    projects onto the film widened by the pyramid's margin (0.1% of the film): brute
    force with sensor.sample_direction at 64 points on each of 2,000 random segments."""
    sensor = _sensor()
    view = ViewPyramid(sensor)
    rng = np.random.default_rng(1)
    n, k = 2000, 64
    o = rng.uniform(-2.0, 3.0, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    length = rng.uniform(0.1, 6.0, n)
    s_in, s_out, seen = view.clip(mi.Point3f(*o.T), mi.Vector3f(*d.T), mi.Float(length))
    s_in, s_out, seen = np.asarray(s_in), np.asarray(s_out), np.asarray(seen)
    s = (np.arange(k) + 0.5) / k * length[:, None]  # n × k
    points = o[:, None, :] + s[..., None] * d[:, None, :]
    it = dr.zeros(mi.Interaction3f, n * k)
    it.p = mi.Point3f(*points.reshape(-1, 3).T)
    ds, _ = sensor.sample_direction(it, mi.Point2f(0.5, 0.5))
    on_film = (np.asarray(ds.pdf) > 0).reshape(n, k)
    uv = np.asarray(ds.uv).T.reshape(n, k, 2) / [64, 48]  # film coordinates in [0, 1] on the film
    inside = seen[:, None] & (s >= s_in[:, None]) & (s <= s_out[:, None])
    assert on_film.sum() > 5000 and (~on_film).sum() > 5000
    assert np.all(inside[on_film]), "clipped away a point the sensor sees"
    assert np.all((uv[inside] > -2e-3) & (uv[inside] < 1 + 2e-3)), "kept a point beyond the film's margin"
    with pytest.raises(ValueError, match="pinhole"):
        ViewPyramid(mi.load_dict({"type": "orthographic"}))
    # the pixel angle: the film's centre row spacing, 40° over 48 rows
    assert float(np.asarray(view.pixel_angle)[0]) == pytest.approx(2 * math.tan(math.radians(20.0)) / 48, rel=1e-3)


def test_a_narrow_view_keeps_its_pixel_angle_and_a_bounded_count_of_connections():
    """fov_y 0.1° over 12 rows: the pixel angle by acos of a float32 dot was 0 (cos of
    1.5e-4 rad rounds to 1), so every segment got an unbounded count of connections (a
    batch of a 16×12 image ran 147 s; at 1e-30° it never ended). Now the angle is right
    to float32 (atan2) and a segment gets at most width + height connections."""
    sensor = mi.load_dict({"type": "perspective", "fov": 0.1, "fov_axis": "y", "near_clip": 1e-3,
                           "to_world": mi.ScalarTransform4f().look_at(origin=[0.0, 1.2, 4.5], target=[0.0, 1.0, 0.0],
                                                                      up=[0.0, 1.0, 0.0]),
                           "film": {"type": "hdrfilm", "width": 16, "height": 12, "rfilter": {"type": "box"}}})
    view = ViewPyramid(sensor)
    assert float(np.asarray(view.pixel_angle)[0]) == pytest.approx(2 * math.tan(math.radians(0.05)) / 12, rel=1e-3)
    scene = _near_camera_scene()
    tracer = _tracer(VolumetricLightTracer, scene, mi.load_dict(to_mitsuba(scene)), "fog",
                     geometry_per_connection=1e-9)  # the geometric term asks for millions
    eye, target = np.array([0.0, 1.2, 4.5]), np.array([0.0, 1.0, 0.0])
    forward = (target - eye) / np.linalg.norm(target - eye)
    ray = mi.Ray3f(mi.Point3f(*(eye + 2.0 * forward - [0.01, 0.0, 0.0]).tolist()), mi.Vector3f(1.0, 0.0, 0.0))
    _, _, seen, n = tracer.connections(view, ray, mi.Float(0.02))  # across the whole view
    assert bool(np.asarray(seen)[0]) and 1 <= int(np.asarray(n)[0]) <= 16 + 12


def test_subtended_angle_is_the_geometric_term():
    """Δθ / D = ∫ dt / |x(t) − eye|² (composite Simpson, 20,001 points, on segments whose
    line passes 1 mm to 3 m from the eye)."""
    rng = np.random.default_rng(2)
    eye = np.array([0.1, 1.0, 2.0])
    for D in (1e-3, 0.05, 0.5, 3.0):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        side = np.cross(d, rng.normal(size=3))
        side /= np.linalg.norm(side)
        origin = eye + D * side - rng.uniform(0.0, 2.0) * d
        length = rng.uniform(0.5, 4.0)
        angle, dist = subtended_angle(mi.Point3f(*origin.tolist()), mi.Vector3f(*d.tolist()), mi.Float(length),
                                      mi.Point3f(*eye.tolist()))
        t = np.linspace(0.0, length, 20001)
        f = 1.0 / np.sum((origin + t[:, None] * d - eye) ** 2, axis=1)
        h = t[1] - t[0]
        integral = h / 3 * (f[0] + f[-1] + 4 * f[1:-1:2].sum() + 2 * f[2:-1:2].sum())
        assert float(dist[0]) == pytest.approx(D, rel=1e-4)
        assert float(angle[0]) / float(dist[0]) == pytest.approx(integral, rel=1e-3), D


def test_connection_count():
    """n = ⌈Δθ / (D · geometry_per_connection)⌉, at least 1, at most one per pixel of the
    segment's image (Δθ / pixel angle)."""
    scene = _near_camera_scene()
    mi_scene = mi.load_dict(to_mitsuba(scene))
    tracer = _tracer(VolumetricLightTracer, scene, mi_scene, "fog", geometry_per_connection=0.01)
    view = ViewPyramid(mi_scene.sensors()[0])
    eye = np.array(scene.camera.position)
    forward = np.subtract(scene.camera.target, eye)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    # segments across the view, centred on its axis at distance D, half length h: Δθ = 2·atan(h / D)
    D = np.array([2.0, 2.0, 0.5])
    h = np.array([1e-3, 0.3, 0.1])
    origins = eye + D[:, None] * forward - h[:, None] * right
    ray = mi.Ray3f(mi.Point3f(*origins.T), mi.Vector3f(*np.tile(right, (3, 1)).T))
    _, _, seen, n = tracer.connections(view, ray, mi.Float(2 * h))
    angle = 2 * np.arctan(h / D)
    pixel = 2 * math.tan(math.radians(20.0)) / H
    expected = np.maximum(1, np.ceil(np.minimum(angle / (D * 0.01), angle / pixel)))
    # one; by the geometric term (0.298 / 0.02 = 14.9); by the pixels crossed (0.395 / 0.0152 = 26.0)
    assert list(expected) == [1, 15, 27]
    assert np.all(np.asarray(seen)) and np.array_equal(np.asarray(n), expected.astype(np.uint32)), (n, expected)


def test_geometry_per_connection_is_a_property():
    tracer = mi.load_dict({"type": "vc_lighttracer", "geometry_per_connection": 0.01})
    assert tracer.geometry_per_connection == 0.01
    props = mi.Properties()
    props["geometry_per_connection"] = 0.0
    with pytest.raises(ValueError, match="geometry_per_connection"):
        VolumetricLightTracer(props)


def test_connections_unbiased_near_camera():
    """Where the single connection made fireflies (beams through the eye's neighbourhood),
    the light tracer's fog still matches the camera integrator's fog, an independent
    estimator (per-pixel z-test, Šidák, α = 0.01, ≥ 99% of pixels), which the single
    connection fails (docs/decisions.md "Stratified camera connections")."""
    scene = _near_camera_scene()
    mi_scene = mi.load_dict(to_mitsuba(scene))
    camera = configure(SingleScatterIntegrator(), scene, mi_scene)
    fog = _batches(mi_scene, camera, 64, 8, slice(3, 6), seed0=500)
    light = _batches(mi_scene, _tracer(VolumetricLightTracer, scene, mi_scene, "fog"), 64, 8, slice(0, 3), seed0=0)
    result = z_test(fog.mean(0), fog.var(0, ddof=1) / 8, light.mean(0), light.var(0, ddof=1) / 8)
    assert result.passed, result
    # the energy too: image totals within 3 standard errors
    a, b = fog.sum(axis=(1, 2, 3)), light.sum(axis=(1, 2, 3))
    assert abs(a.mean() - b.mean()) < 3 * math.hypot(a.std(ddof=1), b.std(ddof=1)) / math.sqrt(8)


def test_connections_remove_the_fireflies():
    """Same photons, same scene: the noise floor Σ var / Σ mean² of the caustic (glass
    sphere above the camera) and of the fog, single connection vs stratified connections:
    ≥ 15× lower (measured 69–86×; the single connection's floor estimate is itself
    heavy-tailed: docs/decisions.md "Stratified camera connections"). Their image totals
    agree within 3 σ."""
    scene = _near_camera_scene(glass=True)
    mi_scene = mi.load_dict(to_mitsuba(scene))
    for mode in ("caustic", "fog"):
        old = _batches(mi_scene, _tracer(SingleConnection, scene, mi_scene, mode), 64, 8, slice(0, 3), seed0=0)
        new = _batches(mi_scene, _tracer(VolumetricLightTracer, scene, mi_scene, mode), 64, 8, slice(0, 3), seed0=100)
        floors = [float((x.var(0, ddof=1) / 8).sum() / (x.mean(0) ** 2).sum()) for x in (old, new)]
        print(mode, "noise floor single / stratified connections", floors, floors[0] / floors[1])
        assert floors[0] > 15 * floors[1], (mode, floors)
        a, b = old.sum(axis=(1, 2, 3)), new.sum(axis=(1, 2, 3))
        assert abs(a.mean() - b.mean()) < 3 * math.hypot(a.std(ddof=1), b.std(ddof=1)) / math.sqrt(8), (mode, a, b)
