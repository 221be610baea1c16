"""Scenes built in code for analytic approx tests."""

from __future__ import annotations

import math

import numpy as np

from volcaustics.scenes.model import (
    Camera,
    DiffuseSurface,
    Medium,
    MeshSpec,
    Phase,
    Scene,
    SpecularObject,
    SpotLight,
    Transform,
)


def sphere_spec(radius, center, subdivisions=48):
    return MeshSpec(generator="sphere", params=(("radius", float(radius)), ("subdivisions", subdivisions)),
                    transform=Transform(translate=tuple(float(c) for c in center)))


def shell_spec(radius, inner_radius, center, subdivisions=48):
    return MeshSpec(generator="shell", params=(("inner_radius", float(inner_radius)), ("radius", float(radius)),
                                               ("subdivisions", subdivisions)),
                    transform=Transform(translate=tuple(float(c) for c in center)))


def make_scene(specular=(), *, light_pos=(0.0, 3.0, 0.0), light_dir=(0.0, -1.0, 0.0), cutoff=20.0, beam=None,
               intensity=10.0, sigma_s=0.2, sigma_a=0.0, g=None, floor=True, camera=None, width=64, height=64):
    """specular: iterable of (MeshSpec, ior, absorption RGB)."""
    objs = tuple(SpecularObject(f"s{i}", spec, ior, tuple(ab)) for i, (spec, ior, ab) in enumerate(specular))
    diffuse = ()
    if floor:
        diffuse = (DiffuseSurface("floor", MeshSpec(generator="quad", params=(("size_x", 10.0), ("size_z", 10.0))),
                                  (0.5, 0.5, 0.5)),)
    cam = camera or Camera(position=(0.0, 1.2, 4.5), target=(0.0, 1.0, 0.0), fov_y=36.0, width=width, height=height)
    phase = Phase("hg", g) if g is not None else Phase()
    return Scene(name="test", camera=cam,
                 light=SpotLight(tuple(light_pos), tuple(np.asarray(light_dir) / np.linalg.norm(light_dir)),
                                 (intensity,) * 3, cutoff, beam if beam is not None else 0.75 * cutoff),
                 medium=Medium((sigma_s,) * 3, (sigma_a,) * 3, phase), specular=objs, diffuse=diffuse)


def ray_sphere(origin, dirs, center, radius):
    """Entry and exit distances of rays origin + t·dirs (...×3 unit) with a sphere; nan on a miss."""
    oc = np.asarray(origin, np.float64) - np.asarray(center, np.float64)
    b = dirs @ oc
    c = oc @ oc - radius * radius
    disc = b * b - c
    sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
    return -b - sq, -b + sq


def pixel_ray(cam, x, y):
    """Independent pinhole model: unit direction through image point (x, y) in pixels,
    x to the right from the left edge, y down from the top edge (pixel centres at +0.5)."""
    fwd = np.subtract(cam.target, cam.position).astype(float)
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, cam.up)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    half = np.tan(np.radians(cam.fov_y) / 2)
    d = fwd + (x / cam.width * 2 - 1) * half * cam.width / cam.height * right + (1 - y / cam.height * 2) * half * up
    return d / np.linalg.norm(d)


def spot_falloff64(light, w):
    """Mitsuba's spot falloff in float64 from its definition (spot.cpp): 1 inside
    beam_width, linear in angle to 0 at cutoff_angle."""
    cos_theta = float(np.dot(w, light.direction))
    cutoff, beam = np.radians(light.cutoff_angle), np.radians(light.beam_width)
    if cos_theta <= np.cos(cutoff):
        return 0.0
    if cos_theta >= np.cos(beam):
        return 1.0
    return float((cutoff - np.arccos(cos_theta)) / (cutoff - beam))


def fog_quadrature(scene, eye, d, s_end):
    """Single scattering of the unoccluded spot light along eye + s·d, s in [0, s_end]:
    ∫ σs p(θ) I falloff(ω)/r² exp(−σt (r + s)) ds by scipy quadrature (red channel)."""
    from scipy import integrate

    light, medium = scene.light, scene.medium
    g = medium.phase.g if medium.phase.kind == "hg" else 0.0
    sigma_s, sigma_t = medium.sigma_s[0], medium.sigma_t[0]

    def integrand(s):
        to_x = eye + d * s - np.asarray(light.position)
        r = np.linalg.norm(to_x)
        w = to_x / r
        cos_t = float(w @ -d)
        phase = (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * cos_t) ** 1.5)
        return sigma_s * phase * light.intensity[0] * spot_falloff64(light, w) / r**2 * np.exp(-sigma_t * (r + s))

    return integrate.quad(integrand, 0.0, s_end, limit=400, points=np.linspace(0, s_end, 40)[1:-1])[0]


def pixel_solid_angles(fov_y: float, size: int) -> tuple:
    """(edges, omega) of a square size × size image of vertical field of view fov_y
    (degrees): the pixel edges on the image plane at unit distance and each pixel's exact
    solid angle (size × size, rows bottom-up as GL draws them)."""
    half = math.tan(math.radians(fov_y) / 2)
    edges = np.linspace(-half, half, size + 1)

    def f(x, y):
        return np.arctan2(x * y, np.sqrt(1 + x * x + y * y))

    x0, y0 = np.meshgrid(edges[:-1], edges[:-1])
    x1, y1 = np.meshgrid(edges[1:], edges[1:])
    return edges, f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)
