"""The Dr.Jit sampling and geometry the reference's integrators share: the Henyey–Greenstein
phase function and its sampling, equiangular sampling toward a point (Kulla & Fajardo
2012), the subtended angle of a segment seen from a point, the view pyramid a medium
segment is clipped to, and the interval of a ray inside the spot's cone."""

from __future__ import annotations

import math
from typing import Any

import drjit as dr

from ..mi_setup import mitsuba

mi = mitsuba()

INV_FOUR_PI = 1.0 / (4.0 * math.pi)

GEOMETRY_PER_CONNECTION = 0.0025  # 1/m: VolumetricLightTracer's default, measured in bench/reference_fireflies.py


def hg_phase(cos_theta: Any, g: float) -> Any:
    """Henyey–Greenstein phase (per sr); cos_theta between propagation before and after."""
    if g == 0.0:
        return dr.full(mi.Float, INV_FOUR_PI, dr.width(cos_theta))
    denom = 1.0 + g * g - 2.0 * g * cos_theta
    return INV_FOUR_PI * (1.0 - g * g) / (denom * dr.sqrt(denom))


def hg_sample(d: Any, g: float, sample: Any) -> Any:
    """Direction scattered from propagation direction ``d`` by HG sampling."""
    if g == 0.0:
        cos_theta = 1.0 - 2.0 * sample.x
    else:
        s = (1.0 - g * g) / (1.0 - g + 2.0 * g * sample.x)
        cos_theta = (1.0 + g * g - s * s) / (2.0 * g)
    sin_theta = dr.sqrt(dr.maximum(0.0, 1.0 - cos_theta * cos_theta))
    phi = 2.0 * math.pi * sample.y
    frame = mi.Frame3f(d)
    return frame.to_world(mi.Vector3f(sin_theta * dr.cos(phi), sin_theta * dr.sin(phi), cos_theta))


def closest_approach(origin: Any, d: Any, target: Any) -> tuple[Any, Any]:
    """Where the line origin + t·d (unit d) passes ``target``: the parameter ``delta`` of
    its closest point and the distance ``dist`` from it to ``target`` (≥ 1e-6)."""
    delta = dr.dot(target - origin, d)
    dist = dr.maximum(dr.norm(target - origin - delta * d), 1e-6)
    return delta, dist


def subtended_angle(origin: Any, d: Any, length: Any, target: Any) -> tuple[Any, Any]:
    """Angle θb − θa that the segment origin + t·d, t in [0, length], subtends at
    ``target``, and its line's distance D to ``target``. Their ratio is the segment's
    geometric term seen from ``target``: ∫ dt / |x(t) − target|² = (θb − θa) / D."""
    delta, dist = closest_approach(origin, d, target)
    return dr.atan2(length - delta, dist) - dr.atan2(-delta, dist), dist


def equiangular(origin: Any, d: Any, length: Any, target: Any, sample: Any) -> tuple[Any, Any]:
    """Distance t in [0, length] along origin + t·d with pdf ∝ 1/|x(t) − target|²
    (Kulla & Fajardo 2012); returns (t, pdf)."""
    delta, dist = closest_approach(origin, d, target)
    theta_a = dr.atan2(-delta, dist)
    theta_b = dr.atan2(length - delta, dist)
    theta = dr.lerp(theta_a, theta_b, sample)
    t = dr.clip(delta + dist * dr.tan(theta), 0.0, length)
    pdf = dist / (dr.maximum(theta_b - theta_a, 1e-12) * (dist * dist + (t - delta) * (t - delta)))
    return t, pdf


class ViewPyramid:
    """What a pinhole sensor sees: the pyramid from its eye through the film's edges
    (widened by ``margin`` of the film on every side, so that rounding never cuts off a
    point that projects onto the film), and the angle one pixel subtends at the film's
    centre. Built from the sensor's own rays, symbolically (no evaluation)."""

    def __init__(self, sensor, margin: float = 1e-3):
        if sensor.class_name() != "PerspectiveCamera":
            raise ValueError(f"vc_lighttracer connects to a pinhole camera (perspective), not {sensor.class_name()}")
        self.eye = sensor.world_transform().translation()
        lo, hi = -margin, 1.0 + margin

        def direction(u, v):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(u, v), mi.Point2f(0.5, 0.5))
            return ray.d

        corners = [direction(lo, lo), direction(hi, lo), direction(hi, hi), direction(lo, hi)]
        centre = direction(0.5, 0.5)
        self.normals = []  # inward normals of the four side planes through the eye
        for a, b in zip(corners, corners[1:] + corners[:1]):
            n = dr.cross(a, b)
            self.normals.append(dr.select(dr.dot(n, centre) < 0.0, -n, n))
        size = sensor.film().crop_size()
        below = direction(0.5, 0.5 + 1.0 / size.y)
        # atan2, not acos of the dot: float32 acos near 1 resolves only ~3.5e-4 rad (0 for
        # a narrow view, which made the count of connections infinite)
        self.pixel_angle = dr.atan2(dr.norm(dr.cross(centre, below)), dr.dot(centre, below))
        self.pixels = mi.Float(size.x + size.y)  # the most pixels a segment's image crosses

    def clip(self, origin: Any, d: Any, length: Any) -> tuple[Any, Any, Any]:
        """Part [s_in, s_out] of origin + s·d, s in [0, length], inside the pyramid: the
        intersection of the four half-spaces n·(x − eye) ≥ 0 (one interval, as the pyramid
        is convex). Returns (s_in, s_out, nonempty)."""
        s_in, s_out = dr.zeros(mi.Float, dr.width(length)), mi.Float(length)
        for n in self.normals:
            a, b = dr.dot(n, origin - self.eye), dr.dot(n, d)  # n·(x(s) − eye) = a + b·s
            s_in = dr.select(b > 0.0, dr.maximum(s_in, -a / b), s_in)
            s_out = dr.select(b < 0.0, dr.minimum(s_out, -a / b), s_out)
            s_out = dr.select((b == 0.0) & (a < 0.0), -1.0, s_out)
        return s_in, s_out, s_out > s_in


def cone_interval(o: Any, d: Any, s_end: Any, apex: Any, axis: Any, cos_cutoff: float) -> tuple[Any, Any, Any]:
    """Part [s_in, s_out] of the ray o + s·d, s in [0, s_end], inside the cone (apex,
    unit axis, half-angle with cosine cos_cutoff < 1); the cone is convex so the part is
    one interval, found between the roots of the cone's quadratic by testing the
    midpoints of the pieces. Returns (s_in, s_out, nonempty)."""
    q = o - apex
    c2 = cos_cutoff * cos_cutoff
    qa, da = dr.dot(q, axis), dr.dot(d, axis)
    a = da * da - c2
    b = 2.0 * (qa * da - c2 * dr.dot(q, d))
    c = qa * qa - c2 * dr.dot(q, q)
    disc = b * b - 4.0 * a * c
    ok = (disc >= 0.0) & (dr.abs(a) > 1e-12)
    sq = dr.sqrt(dr.maximum(disc, 0.0))
    r0, r1 = (-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)
    p1 = dr.select(ok, dr.clip(dr.minimum(r0, r1), 0.0, s_end), s_end)
    p2 = dr.select(ok, dr.clip(dr.maximum(r0, r1), 0.0, s_end), s_end)

    def inside(s):
        x = q + d * s
        return dr.dot(x, axis) > cos_cutoff * dr.norm(x)

    in01, in12, in23 = inside(0.5 * p1), inside(0.5 * (p1 + p2)), inside(0.5 * (p2 + s_end))
    in01 &= p1 > 0.0
    in12 &= p2 > p1
    in23 &= s_end > p2
    s_in = dr.select(in01, 0.0, dr.select(in12, p1, p2))
    s_out = dr.select(in23, s_end, dr.select(in12, p2, p1))
    return s_in, s_out, (in01 | in12 | in23) & (s_out > s_in)
