"""Scenes built in code for analytic approx tests."""

from __future__ import annotations

import numpy as np

from scenes.model import (Camera, DiffuseSurface, Medium, MeshSpec, Phase, Scene, SpecularObject, SpotLight,
                          Transform)


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
