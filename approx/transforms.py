"""Camera and light matrices in the OpenGL convention (column vectors, clip z in [-1, 1]).

Matrices are 4×4 float64 numpy arrays for column vectors (``clip = P @ V @ x``);
upload them to GLSL with :func:`gl_matrix` (column-major bytes).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def look_at(position: ArrayLike, target: ArrayLike, up: ArrayLike) -> np.ndarray:
    """World-to-view matrix: camera at ``position`` looking at ``target`` (view −z), ``up`` roughly +y."""
    eye = np.asarray(position, dtype=np.float64)
    f = np.asarray(target, dtype=np.float64) - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, np.asarray(up, dtype=np.float64))
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL projection for a vertical field of view in degrees."""
    f = 1.0 / math.tan(math.radians(fov_y_deg) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def gl_matrix(m: np.ndarray) -> bytes:
    """Column-major float32 bytes for a GLSL ``mat4`` uniform."""
    return np.asarray(m, dtype=np.float32).T.tobytes()
