"""A scene file's ``[animation]`` table: tracks, keyframes and the frames they make, each
frame checked as a scene (``scenes.loader`` calls it after the static scene)."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from .animation import FPS_RANGE, MAX_FRAMES, OBJECT_PATHS, TRACK_PATHS, Animation, Track, aim, track_kind
from .mesh import winding_number, within_box
from .model import Scene, Transform
from .toml_values import (
    COORDINATE_LIMIT,
    Table,
    check_view,
    direction_value,
    euler_value,
    integer_in,
    object_list,
    ranged,
    rgb_value,
    string_value,
    vec3_value,
    view_angle,
)

if TYPE_CHECKING:
    from .toml_values import Context


def _track_values(kind: str) -> Callable:
    return {"point": vec3_value, "direction": direction_value, "rgb": rgb_value(0.0, unit="1/m or W/sr"),
            "angle": lambda c, k, v: (view_angle(c, k, v),), "euler": euler_value,
            "scale": lambda c, k, v: (ranged(1.0 / COORDINATE_LIMIT, COORDINATE_LIMIT)(c, k, v),)}[kind]


def _track(ctx, key, value, index, scene: Scene) -> Track:
    t = Table(ctx, key, value)
    path = t.get("path", string_value)
    try:
        kind, interpolation = track_kind(path)
    except KeyError:
        raise ctx.error(f"{key}.path", path, "expected one of " + ", ".join(
            [*TRACK_PATHS, *(f"specular.NAME.{k}" for k in OBJECT_PATHS)])) from None
    if path.startswith("specular."):
        name = path[len("specular."):path.rindex(".")]
        names = [o.name for o in scene.specular]
        if name not in names:
            raise ctx.error(f"{key}.path", path,
                            f"NAME must be a specular object's name ({', '.join(names) or 'none'})")
    frames = t.get("frame", _keyframes)
    values = t.get("value", lambda c, k, v: _key_values(c, k, v, len(frames), kind))
    t.finish()
    if path == "light.intensity":
        for j, v in enumerate(values):
            if not max(v) > 0:
                raise ctx.error(f"{key}.value[{j}]", list(v),
                                "must be > 0 in some channel: a dark light lights nothing")
    if interpolation == "slerp" and kind == "direction":
        for j in range(1, len(values)):
            if sum(a * b for a, b in zip(values[j - 1], values[j])) < -1 + 1e-9:
                raise ctx.error(f"{key}.value[{j}]", list(values[j]), "must not be opposite to the key before it "
                                                                     "(the arc between them is not unique)")
    return Track(path, frames, values)


def _keyframes(ctx, key, v):
    if not isinstance(v, list) or not v:
        raise ctx.error(key, v, "expected a non-empty list of increasing frame numbers >= 0")
    frames = tuple(ranged(0.0, MAX_FRAMES)(ctx, f"{key}[{i}]", x) for i, x in enumerate(v))
    for i in range(1, len(frames)):
        if not frames[i] > frames[i - 1]:
            raise ctx.error(f"{key}[{i}]", v[i], f"expected frame numbers increasing (after {frames[i - 1]:g})")
    return frames


def _key_values(ctx, key, v, count: int, kind: str):
    if not isinstance(v, list) or len(v) != count:
        raise ctx.error(key, v, f"expected a list of {count} values, one per keyframe in `frame`")
    parse = _track_values(kind)
    return tuple(tuple(parse(ctx, f"{key}[{i}]", x)) for i, x in enumerate(v))


def parse_animation(ctx: Context, value: object, scene: Scene) -> Animation:
    t = Table(ctx, "animation", value)
    frames = t.get("frames", integer_in(1, MAX_FRAMES))
    fps = t.get("fps", ranged(*FPS_RANGE, unit="frames per second (what the video writers store)"), 24.0)
    tracks = t.get("track", lambda c, k, v: object_list(c, k, v, lambda c2, k2, v2, i: _track(c2, k2, v2, i, scene)),
                   ())
    t.finish()
    paths = [tr.path for tr in tracks]
    for i, path in enumerate(paths):
        if path in paths[:i]:
            raise ctx.error(f"animation.track[{i}].path", path, "each path may have one track")
    if "light.target" in paths and "light.direction" in paths:
        raise ctx.error(f"animation.track[{paths.index('light.target')}].path", "light.target",
                        "not with a light.direction track: the target sets the direction")
    animation = Animation(frames, fps, tracks)
    _check_frames(ctx, animation, scene)
    return animation


def _check_frames(ctx, animation: Animation, scene: Scene) -> None:
    """Every frame is a valid scene: the camera looks somewhere from outside the glass,
    the light aims somewhere from outside the glass."""
    paths = {tr.path for tr in animation.tracks}
    moves = any(p.startswith(("camera.", "specular.")) or p == "light.position" for p in paths)
    for frame in range(animation.frames):
        values = {tr.path: tr.at(frame) for tr in animation.tracks}
        where = f" (animation frame {frame})"
        if "light.target" in values:
            position = values.get("light.position", scene.light.position)
            try:
                aim(position, values["light.target"])
            except ValueError:
                raise ctx.error("light.position", list(position), f"must differ from light.target{where}") from None
        if moves:
            at = animation.scene_at(scene, frame)
            check_view(ctx, at.camera, where)
            for i, obj in enumerate(at.specular):  # in object space: no mesh is built per frame
                mesh = replace(obj.mesh, transform=Transform()).load()
                for what, position in (("camera", at.camera.position), ("light", at.light.position)):
                    local = np.linalg.solve(obj.mesh.transform.matrix(), [*position, 1.0])[:3]
                    if within_box(mesh, local) and winding_number(mesh, local) > 0.5:
                        raise ctx.error(f"{what}.position", list(position),
                                        f"the {what} must be outside every specular object (it is inside "
                                        f"specular[{i}] '{obj.name}'){where}")


# --- entry points -----------------------------------------------------------------
