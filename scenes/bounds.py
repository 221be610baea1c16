"""The scene box: where the medium is.

docs/conventions.md says the homogeneous medium "fills the scene outside the objects". Both
renderers make that precise the same way: the medium fills the axis-aligned box
around every mesh, the light and the camera (plus a margin of 1e-3 of its
diagonal) and there is vacuum outside. Photons leaving the box never return (it
is convex and holds all geometry), camera rays see fog only inside it;
:func:`box_exit` is how far a ray inside it runs before it leaves.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .model import DiffuseSurface, Scene, SpecularObject

MARGIN = 1e-3


def medium_bounds(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) corners of the scene box, each (3,) float64, metres."""
    points = [np.asarray([scene.light.position, scene.camera.position], np.float64)]
    objects: tuple[SpecularObject | DiffuseSurface, ...] = (*scene.specular, *scene.diffuse)
    for obj in objects:
        points.append(obj.mesh.load().vertices)
    allp = np.concatenate(points)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    margin = MARGIN * float(np.linalg.norm(hi - lo))
    return lo - margin, hi + margin


def box_exit(origins: np.ndarray, directions: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Distance along each ray to the exit of the box [lo, hi] (numpy twin of
    ``approx/shaders/common/box.glsl``).

    origins: N×3 points inside the box (m); directions: N×3 unit vectors (zero
    components allowed); lo, hi: (3,) corners (m), e.g. from :func:`medium_bounds`.
    Returns N float64 distances ≥ 0 (m).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / directions
        t_far = np.maximum((lo - origins) * inv, (hi - origins) * inv)
    return np.maximum(np.nanmin(t_far, axis=1), 0.0)
