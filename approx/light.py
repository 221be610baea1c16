"""The spot light's frustum, its texel geometry and Mitsuba's falloff, on the CPU.

The light's maps (layers, photons, shadows) are square perspective images whose
field of view is the cutoff cone: half-angle ``cutoff_angle`` in both axes, so
the image plane at unit distance spans [-tan(cutoff), tan(cutoff)]².
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .transforms import look_at, perspective

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene, SpotLight


def spot_constants(light: SpotLight) -> dict:
    """Uniform values of ``common/spot.glsl``, computed in float32 like Mitsuba's spot.cpp."""
    f32 = np.float32
    cutoff = f32(light.cutoff_angle) * f32(math.pi / 180.0)
    beam = f32(light.beam_width) * f32(math.pi / 180.0)
    width = f32(cutoff - beam)
    return {
        "spot_cutoff_angle": float(cutoff),
        "spot_cos_cutoff": float(np.cos(cutoff, dtype=f32)),
        "spot_cos_beam": float(np.cos(beam, dtype=f32)),
        "spot_inv_transition": float(f32(1.0) / width) if width > 0 else 0.0,
        "light_position": tuple(float(x) for x in light.position),
        "light_direction": tuple(float(x) for x in light.direction),
        "light_intensity": tuple(float(x) for x in light.intensity),
    }


def spot_falloff(light: SpotLight, directions: np.ndarray) -> np.ndarray:
    """Mitsuba's spot falloff for unit world directions (...×3) leaving the light; float32, in [0, 1]."""
    c = spot_constants(light)
    cos_theta = (np.asarray(directions, np.float32) @ np.asarray(light.direction, np.float32)).astype(np.float32)
    ramp = ((np.float32(c["spot_cutoff_angle"]) - np.arccos(np.clip(cos_theta, -1, 1)))
            * np.float32(c["spot_inv_transition"]))
    beam = np.where(cos_theta >= np.float32(c["spot_cos_beam"]), np.float32(1.0), ramp)
    return np.where(cos_theta > np.float32(c["spot_cos_cutoff"]), beam, np.float32(0.0)).astype(np.float32)


def _rect_solid_angle(x0, x1, y0, y1):
    """Exact solid angle of the rectangle [x0,x1]×[y0,y1] on the plane z = 1 seen from the origin."""
    def f(x, y):
        return np.arctan2(x * y, np.sqrt(1.0 + x * x + y * y))
    return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)


@dataclass(frozen=True, eq=False)
class LightFrustum:
    """Square perspective frustum of the spot light (GL conventions, see approx.transforms)."""

    position: np.ndarray  # (3,) float64
    direction: np.ndarray  # (3,) unit spot axis
    tan_half: float  # tan(cutoff_angle)
    near: float
    far: float
    view: np.ndarray  # 4×4 world→light view
    proj: np.ndarray  # 4×4 light projection

    @classmethod
    def for_scene(cls, scene: Scene, bounds_min: np.ndarray, bounds_max: np.ndarray) -> "LightFrustum":
        light = scene.light
        pos = np.asarray(light.position, np.float64)
        axis = np.asarray(light.direction, np.float64)
        up = np.array([0.0, 1.0, 0.0]) if abs(axis[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
        corners = np.array([[x, y, z] for x in (bounds_min[0], bounds_max[0])
                            for y in (bounds_min[1], bounds_max[1]) for z in (bounds_min[2], bounds_max[2])])
        far = max(float(np.linalg.norm(corners - pos, axis=1).max()) * 1.01, 1e-2)
        near = far * 1e-4
        tan_half = math.tan(math.radians(light.cutoff_angle))
        fov = 2.0 * math.degrees(math.atan(tan_half))
        return cls(pos, axis, tan_half, near, far, look_at(pos, pos + axis, up), perspective(fov, 1.0, near, far))

    @property
    def view_proj(self) -> np.ndarray:
        return self.proj @ self.view

    @property
    def basis(self) -> np.ndarray:
        """3×3, columns: the light's right, up and spot axis (world); a point (x, y) of
        the image plane at unit distance lies in direction basis @ (x, y, 1)."""
        return np.stack([self.view[0, :3], self.view[1, :3], self.direction], axis=1)

    def texel_directions(self, res: int) -> np.ndarray:
        """Unit world directions through texel centres, res×res×3 (row 0 = bottom, GL order)."""
        c = (np.arange(res) + 0.5) / res * 2.0 - 1.0
        x, y = np.meshgrid(c * self.tan_half, c * self.tan_half, indexing="xy")
        local = np.stack([x, y, -np.ones_like(x)], axis=-1)
        world = local @ self.view[:3, :3]  # rows of view are the light's axes
        return world / np.linalg.norm(world, axis=-1, keepdims=True)

    def texel_solid_angles(self, res: int) -> np.ndarray:
        """Exact solid angle (sr) of each texel, res×res float64."""
        edges = np.linspace(-self.tan_half, self.tan_half, res + 1)
        lo, hi = edges[:-1], edges[1:]
        # rows index y (GL order, bottom first), columns index x
        return _rect_solid_angle(lo[None, :], hi[None, :], lo[:, None], hi[:, None])
