"""Animated scenes (docs/over-time.md: keyframed tracks over a scene.

A scene file's optional ``[animation]`` table::

    [animation]
    frames = 24                   # frames 0 … frames − 1
    fps = 12                      # playback rate of the videos (frames per second)

    [[animation.track]]
    path = "light.position"       # what the track drives (TRACK_PATHS)
    frame = [0, 12, 24]           # keyframes: frame numbers, increasing (may be fractional)
    value = [[0.6, 2.5, 0], [-0.6, 2.5, 0], [0.6, 2.5, 0]]

Between keys a value is interpolated linearly (positions, colours, coefficients,
angles, scales); unit directions and rotations by spherical linear interpolation
(slerp: constant angular speed); before the first key and after the last it holds.
``light.target`` aims the spot at a point each frame (direction = target − position).
A frame is an ordinary static :class:`scenes.model.Scene` (:meth:`Animation.scene_at`),
so both renderers, the reference cache (per frame's ``scene_hash``) and every metric
see nothing new; the animation itself does not enter the static scene's hash.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .model import Scene

# path → (value kind, interpolation). Object paths are "specular.NAME.translate" etc.
TRACK_PATHS = {
    "light.position": ("point", "linear"),
    "light.direction": ("direction", "slerp"),
    "light.target": ("point", "linear"),
    "light.intensity": ("rgb", "linear"),
    "medium.sigma_s": ("rgb", "linear"),
    "medium.sigma_a": ("rgb", "linear"),
    "camera.position": ("point", "linear"),
    "camera.target": ("point", "linear"),
    "camera.fov_y": ("angle", "linear"),
}
OBJECT_PATHS = {"translate": ("point", "linear"), "rotate": ("euler", "slerp"), "scale": ("scale", "linear")}
MAX_FRAMES = 10_000
# What the video writers accept (reports.studies.animate.media): a GIF stores a frame's duration in
# 1/100 s in 16 bits (655 s at most), a WebP its timestamps in milliseconds in a C int
# (2^31 over MAX_FRAMES frames); 1e-3 fps failed the GIF, 1e-6 the WebP. The top: 1,000.
FPS_RANGE = (0.01, 1000.0)


@dataclass(frozen=True)
class Track:
    """One keyframed value: ``path`` (TRACK_PATHS or ``specular.NAME.{translate,rotate,scale}``),
    ``frames`` (increasing keyframe numbers) and ``values`` (one per key: a tuple of 3
    floats, or of 1 for a scalar). ``kind`` and ``interpolation`` follow from the path."""

    path: str
    frames: tuple
    values: tuple

    @property
    def kind(self) -> str:
        return track_kind(self.path)[0]

    @property
    def interpolation(self) -> str:
        return track_kind(self.path)[1]

    def at(self, t: float) -> tuple:
        """The value at frame ``t`` (held outside the keys)."""
        return interpolate(self.frames, self.values, t, self.interpolation, self.kind)


@dataclass(frozen=True)
class Animation:
    frames: int
    fps: float
    tracks: tuple

    def scene_at(self, scene: Scene, t: int) -> Scene:
        """The static scene of frame ``t`` (0 ≤ t < frames): ``scene`` with every track's value."""
        if not 0 <= t < self.frames:
            raise ValueError(f"frame {t}: expected 0 ≤ frame < {self.frames}")
        values = {track.path: track.at(t) for track in self.tracks}
        return apply_values(replace(scene, animation=None), values)

    def canonical_dict(self) -> dict:
        return {"frames": self.frames, "fps": float(self.fps),
                "tracks": [{"path": tr.path, "frame": [float(f) for f in tr.frames],
                            "value": [[float(x) for x in v] for v in tr.values]} for tr in self.tracks]}


def track_kind(path: str) -> tuple:
    """(value kind, interpolation) of a track path; KeyError for an unknown one."""
    if path in TRACK_PATHS:
        return TRACK_PATHS[path]
    parts = path.split(".")
    if len(parts) >= 3 and parts[0] == "specular" and parts[-1] in OBJECT_PATHS:
        return OBJECT_PATHS[parts[-1]]
    raise KeyError(path)


def interpolate(frames: Sequence[float], values: Sequence[Sequence[float]], t: float, interpolation: str,
                kind: str) -> tuple:
    """The keyed ``values`` at frame ``t``: linear, or slerp for unit directions and
    rotations (``kind`` "euler": Euler degrees about x, then y, then z, as
    ``scenes.model.Transform``); held before the first key and after the last."""
    keys = np.asarray(frames, np.float64)
    if t <= keys[0]:
        return tuple(values[0])
    if t >= keys[-1]:
        return tuple(values[-1])
    i = int(np.searchsorted(keys, t, side="right")) - 1
    u = (t - keys[i]) / (keys[i + 1] - keys[i])
    a, b = np.asarray(values[i], np.float64), np.asarray(values[i + 1], np.float64)
    if interpolation == "linear":
        return tuple(float(x) for x in (1.0 - u) * a + u * b)
    if kind == "direction":
        return tuple(float(x) for x in slerp_direction(a, b, u))
    from scipy.spatial.transform import Rotation, Slerp  # on first use: every scene file imports this module

    rotations = Rotation.from_euler("xyz", np.stack([a, b]), degrees=True)  # extrinsic x, y, z: Rz·Ry·Rx
    return tuple(float(x) for x in Slerp([0.0, 1.0], rotations)([u]).as_euler("xyz", degrees=True)[0])


def slerp_direction(a: np.ndarray, b: np.ndarray, u: float) -> np.ndarray:
    """The unit vector a fraction ``u`` of the great-circle arc from unit ``a`` to unit ``b``."""
    cos = float(np.clip(np.dot(a, b), -1.0, 1.0))
    angle = math.acos(cos)
    if angle < 1e-9:
        return np.asarray(a, np.float64)
    d = (math.sin((1.0 - u) * angle) * a + math.sin(u * angle) * b) / math.sin(angle)
    return d / np.linalg.norm(d)


def apply_values(scene: Scene, values: dict) -> Scene:
    """``scene`` with the tracks' ``values`` (path → value) set."""
    r = replace
    v = {path: (value[0] if track_kind(path)[0] in ("angle", "scale") else tuple(value))
         for path, value in values.items()}
    camera = r(scene.camera, **{k: v[f"camera.{k}"] for k in ("position", "target", "fov_y") if f"camera.{k}" in v})
    light = r(scene.light, **{k: v[f"light.{k}"] for k in ("position", "direction", "intensity")
                              if f"light.{k}" in v})
    if "light.target" in v:
        light = r(light, direction=aim(light.position, v["light.target"]))
    medium = r(scene.medium, **{k: v[f"medium.{k}"] for k in ("sigma_s", "sigma_a") if f"medium.{k}" in v})
    specular = []
    for obj in scene.specular:
        moves = {k: v[f"specular.{obj.name}.{k}"] for k in OBJECT_PATHS if f"specular.{obj.name}.{k}" in v}
        if moves:
            obj = r(obj, mesh=r(obj.mesh, transform=r(obj.mesh.transform, **moves)))
        specular.append(obj)
    return r(scene, camera=camera, light=light, medium=medium, specular=tuple(specular))


def aim(position: Sequence[float], target: Sequence[float]) -> tuple:
    """The unit direction from ``position`` to ``target`` (ValueError when they meet)."""
    d = np.subtract(target, position, dtype=np.float64)
    norm = float(np.linalg.norm(d))
    if norm < 1e-9:
        raise ValueError(f"light.target {tuple(target)} equals light.position: no direction")
    return tuple(float(x) for x in d / norm)
