"""TOML scene files → validated :class:`scenes.model.Scene`.

Every problem raises :class:`scenes.errors.SceneError` naming the file, the key
(dotted path), the offending value and what is allowed. Nothing else escapes
:func:`load_scene` for any input file. The format, by example::

    name = "my_scene"
    description = "one line"

    [camera]                      # pinhole, box filter
    position = [0, 1.2, 4]        # metres
    target = [0, 0.9, 0]
    up = [0, 1, 0]                # optional
    fov_y = 40                    # vertical field of view, degrees, 0.1 <= fov_y < 180
    width = 512
    height = 512

    [light]                       # Mitsuba `spot`
    position = [0, 2.5, 0]
    direction = [0, -1, 0]        # any length > 0
    intensity = [20, 20, 20]      # W/sr (a number means grey; > 0 in some channel)
    cutoff_angle = 25             # degrees, 0.1 <= cutoff_angle <= 80
    beam_width = 20               # degrees, 0.1 <= beam_width <= cutoff_angle (default 3/4 cutoff)

    [medium]                      # optional; absent = vacuum
    sigma_s = 0.3                 # 1/m, number or RGB list
    sigma_a = [0.02, 0.02, 0.02]
    phase = "isotropic"           # or "hg" with g = 0.3

    [[specular]]                  # closed dielectric meshes
    name = "glass"
    mesh = { generator = "sphere", radius = 0.5, subdivisions = 45 }   # or "file.ply"
    transform = { translate = [0, 1, 0], rotate = [0, 0, 0], scale = 1 }
    ior = 1.5
    absorption = [0, 0, 0]        # 1/m, Beer–Lambert inside

    [[diffuse]]                   # Lambertian
    name = "floor"
    mesh = { generator = "quad", size_x = 8, size_z = 8 }
    albedo = 0.5

    [animation]                   # optional: keyframed tracks (scenes.animation)
    frames = 24
    fps = 12
    [[animation.track]]
    path = "specular.glass.translate"
    frame = [0, 23]
    value = [[0, 0.8, 0], [0, 1.6, 0]]
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import replace
from typing import Any, Callable

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from volcaustics.infra.storage import CacheError, file_sha256, special_file_kind

from .animation import FPS_RANGE, MAX_FRAMES, OBJECT_PATHS, TRACK_PATHS, Animation, Track, aim, track_kind
from .errors import SceneError
from .generators import GENERATORS
from .mesh import MeshReadError, closedness_problem, winding_number
from .model import Camera, DiffuseSurface, Medium, MeshSpec, Phase, Scene, SpecularObject, SpotLight, Transform

_REQUIRED = object()


class _Ctx:
    """Where we are: the file label and the directory mesh paths are relative to."""

    def __init__(self, file: str | None, base_dir: str):
        self.file = file
        self.base_dir = base_dir

    def error(self, key, value, allowed) -> SceneError:
        return SceneError(self.file, key, value, allowed)


class _Table:
    """One TOML table: typed reads by key, then :meth:`finish` rejects unknown keys."""

    def __init__(self, ctx: _Ctx, key: str, table: Any):
        if not isinstance(table, dict):
            raise ctx.error(key or "<top level>", table, "expected a table")
        self.ctx, self.key, self.table, self.used = ctx, key, table, set()

    def path(self, k: str) -> str:
        return f"{self.key}.{k}" if self.key else k

    def get(self, k: str, parse: Callable, default: Any = _REQUIRED):
        self.used.add(k)
        if k not in self.table:
            if default is _REQUIRED:
                raise self.ctx.error(self.path(k), None, "missing required key")
            return default
        return parse(self.ctx, self.path(k), self.table[k])

    def finish(self):
        unknown = sorted(set(self.table) - self.used)
        if unknown:
            allowed = ", ".join(sorted(self.used))
            raise self.ctx.error(self.path(unknown[0]), self.table[unknown[0]], f"unknown key; allowed here: {allowed}")


# --- value parsers (ctx, key, value) -> python value ----------------------------

# What the renderers represent: both compute in float32 (GLSL, Mitsuba's scalar types), where
# 1e300 is inf and products of two values near 1e19 overflow. Every number stays within
# MAGNITUDE_LIMIT; coordinates (positions, translations) and scales within COORDINATE_LIMIT m,
# so that squared distances (≤ 4e12 m²) and float32's 7 digits (0.1 m at 1e6 m) keep meaning.
MAGNITUDE_LIMIT = 1e12
COORDINATE_LIMIT = 1e6


def _number(ctx, key, v, what="a number"):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ctx.error(key, v, f"expected {what}")
    v = float(v)
    if not math.isfinite(v):
        raise ctx.error(key, v, f"expected a finite number ({what})")
    if abs(v) > MAGNITUDE_LIMIT:
        raise ctx.error(key, v, f"expected {what} of magnitude at most {MAGNITUDE_LIMIT:g} (the renderers compute "
                                f"in float32)")
    return v


def _ranged(low=None, high=None, *, low_open=False, high_open=False, unit=""):
    lo_b, hi_b = ("(" if low_open else "["), (")" if high_open else "]")
    what = (f"a number in {lo_b}{'-inf' if low is None else low}, {'inf' if high is None else high}{hi_b}"
            f"{' ' + unit if unit else ''}")

    def parse(ctx, key, v):
        x = _number(ctx, key, v, what)
        if low is not None and (x < low or (low_open and x == low)):
            raise ctx.error(key, v, f"expected {what}")
        if high is not None and (x > high or (high_open and x == high)):
            raise ctx.error(key, v, f"expected {what}")
        return x

    return parse


def _integer(low, high):
    def parse(ctx, key, v):
        if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
            raise ctx.error(key, v, f"expected an integer in [{low}, {high}]")
        return int(v)

    return parse


def _string(ctx, key, v):
    if not isinstance(v, str):
        raise ctx.error(key, v, "expected a string")
    return v


_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}")


def _name(ctx, key, v):
    """A scene's name: it becomes a file name (previews, reports), so letters, digits,
    '_', '.', '-' only, not starting with '.' or '-', at most 64 characters."""
    v = _string(ctx, key, v)
    if not _NAME.fullmatch(v):
        raise ctx.error(key, v, "expected a name of letters, digits, '_', '.' and '-' (not starting with '.' or "
                                "'-', at most 64 characters): it becomes a file name")
    return v


_coordinate = _ranged(-COORDINATE_LIMIT, COORDINATE_LIMIT, unit="m")
# The smallest angle (degrees) of a view or a spot cone: float32 resolves angles near 0
# through cos/acos only to ~0.02 degrees (sqrt(2 * 6e-8) rad); below it the reference's
# spot profile divides by zero and its camera rays degenerate (fov_y 1e-30 hung Mitsuba).
ANGLE_MIN = 0.1
_view_angle = _ranged(ANGLE_MIN, 180, high_open=True, unit="degrees")
# The widest spot cone (degrees): the light maps are a perspective projection of the cone,
# whose edge texels at 80° already subtend cos³ 80° = 0.5% of the centre's solid angle;
# at 89.99° the projection degenerates (the caustic came out as nothing, the reference not).
CONE_MAX = 80.0
_cone_angle = _ranged(ANGLE_MIN, CONE_MAX, unit="degrees")


def _three(element, what: str):
    """A parser of a list of 3 values, each parsed by ``element``; ``what`` names them."""
    def parse(ctx, key, v):
        if not isinstance(v, list) or len(v) != 3:
            raise ctx.error(key, v, f"expected a list of 3 {what}")
        return tuple(element(ctx, f"{key}[{i}]", x) for i, x in enumerate(v))

    return parse


_vec3 = _three(_coordinate, "numbers [x, y, z]")
# rotation angles, bounded like coordinates (float32 keeps 0.1° at 1e6°), named as angles
_euler = _three(_ranged(-COORDINATE_LIMIT, COORDINATE_LIMIT, unit="degrees"),
                "angles in degrees [about x, about y, about z]")


def _rgb(low=0.0, high=None, unit=""):
    one = _ranged(low, high, unit=unit)

    def parse(ctx, key, v):
        if isinstance(v, list):
            if len(v) != 3:
                raise ctx.error(key, v, f"expected a number or a list of 3 (RGB), each {_describe(low, high, unit)}")
            return tuple(one(ctx, f"{key}[{i}]", x) for i, x in enumerate(v))
        x = one(ctx, key, v)
        return (x, x, x)

    return parse


def _describe(low, high, unit):
    text = f">= {low}" if high is None else f"in [{low}, {high}]"
    return f"{text} {unit}".rstrip()


def _direction(ctx, key, v):
    d = _vec3(ctx, key, v)
    n = math.sqrt(sum(x * x for x in d))
    if n < 1e-12:
        raise ctx.error(key, v, "expected a non-zero direction vector")
    return tuple(x / n for x in d)


# --- sections -------------------------------------------------------------------

def _camera(ctx, key, value) -> Camera:
    t = _Table(ctx, key, value)
    cam = Camera(
        position=t.get("position", _vec3),
        target=t.get("target", _vec3),
        up=t.get("up", _direction, (0.0, 1.0, 0.0)),
        fov_y=t.get("fov_y", _view_angle),
        width=t.get("width", _integer(1, 16384), 512),
        height=t.get("height", _integer(1, 16384), 512),
    )
    t.finish()
    _check_view(ctx, cam)
    return cam


def _check_view(ctx, cam: Camera, where: str = "") -> None:
    """The camera looks somewhere: target ≠ position, up not along the view."""
    forward = [b - a for a, b in zip(cam.position, cam.target)]
    norm = math.sqrt(sum(x * x for x in forward))
    if norm < 1e-9:
        raise ctx.error("camera.target", list(cam.target), f"must differ from camera.position{where}")
    cross = [forward[1] * cam.up[2] - forward[2] * cam.up[1],
             forward[2] * cam.up[0] - forward[0] * cam.up[2],
             forward[0] * cam.up[1] - forward[1] * cam.up[0]]
    if math.sqrt(sum(x * x for x in cross)) < 1e-6 * norm:
        raise ctx.error("camera.up", list(cam.up),
                        f"must not be parallel to the view direction (target - position){where}")


def _light(ctx, key, value) -> SpotLight:
    t = _Table(ctx, key, value)
    position = t.get("position", _vec3)
    direction = t.get("direction", _direction)
    intensity = t.get("intensity", _rgb(0.0, unit="W/sr"))
    cutoff = t.get("cutoff_angle", _cone_angle, 20.0)
    beam = t.get("beam_width", _cone_angle, max(0.75 * cutoff, ANGLE_MIN))
    t.finish()
    if not max(intensity) > 0:
        raise ctx.error("light.intensity", list(intensity) if isinstance(intensity, tuple) else intensity,
                        "must be > 0 in some channel: a dark light lights nothing to render or measure")
    if beam > cutoff:
        raise ctx.error("light.beam_width", beam, f"must be <= light.cutoff_angle ({cutoff:g} degrees)")
    return SpotLight(position, direction, intensity, cutoff, beam)


def _medium(ctx, key, value) -> Medium:
    t = _Table(ctx, key, value)
    sigma_s = t.get("sigma_s", _rgb(0.0, unit="1/m"), (0.0, 0.0, 0.0))
    sigma_a = t.get("sigma_a", _rgb(0.0, unit="1/m"), (0.0, 0.0, 0.0))
    kind = t.get("phase", _string, "isotropic")
    if kind not in ("isotropic", "hg"):
        raise ctx.error("medium.phase", kind, 'expected "isotropic" or "hg"')
    g = t.get("g", _ranged(-1, 1, low_open=True, high_open=True), None)
    t.finish()
    if g is not None and kind != "hg":
        raise ctx.error("medium.g", g, 'only allowed with phase = "hg"')
    return Medium(sigma_s, sigma_a, Phase(kind, 0.0 if g is None else g))


def _transform(ctx, key, value) -> Transform:
    t = _Table(ctx, key, value)
    tr = Transform(
        translate=t.get("translate", _vec3, (0.0, 0.0, 0.0)),
        rotate=t.get("rotate", _euler, (0.0, 0.0, 0.0)),
        scale=t.get("scale", _ranged(1.0 / COORDINATE_LIMIT, COORDINATE_LIMIT), 1.0),
    )
    t.finish()
    return tr


def _mesh(ctx, key, value, transform: Transform) -> MeshSpec:
    if isinstance(value, str):
        value = {"path": value}
    if not isinstance(value, dict):
        raise ctx.error(key, value, 'expected a mesh path ("file.ply") or a table { generator = "...", ... }')
    if "path" in value:
        t = _Table(ctx, key, value)
        rel = t.get("path", _string)
        t.finish()
        path = os.path.normpath(os.path.join(ctx.base_dir, os.path.expanduser(rel)))
        kind = special_file_kind(path)
        if kind:  # a device (/dev/zero) would be hashed forever, a FIFO would block
            raise ctx.error(f"{key}.path", rel, f"a readable PLY or OBJ file ({path} is {kind})")
        try:
            digest = file_sha256(path)
        except OSError as exc:
            raise ctx.error(f"{key}.path", rel, f"a readable PLY or OBJ file ({path}: {exc.strerror or exc})") from None
        return MeshSpec(path=path, transform=transform, content_hash=digest)
    t = _Table(ctx, key, value)
    name = t.get("generator", _string)
    if name not in GENERATORS:
        raise ctx.error(f"{key}.generator", name, f"expected one of: {', '.join(GENERATORS)}")
    params = {}
    for pname, spec in GENERATORS[name].params.items():
        parse = _integer(int(spec.low), int(spec.high)) if spec.kind is int else _ranged(spec.low, spec.high)
        params[pname] = t.get(pname, parse, spec.kind(spec.default))
    t.finish()
    return MeshSpec(generator=name, params=tuple(sorted(params.items())), transform=transform)


def _load_checked(ctx, key, spec: MeshSpec, closed: bool):
    try:
        mesh = spec.load()
    except MeshReadError as exc:
        raise ctx.error(key, spec.label, f"a readable PLY or OBJ mesh ({exc})") from None
    except CacheError:  # the cache's problem, not the mesh's
        raise
    except Exception as exc:  # generator failure on odd but in-range parameters
        raise ctx.error(key, spec.label, f"mesh could not be built ({type(exc).__name__}: {exc})") from None
    if len(mesh.faces) == 0:
        raise ctx.error(key, spec.label, "a mesh with at least one triangle")
    if closed:
        problem = closedness_problem(mesh)
        if problem is not None:
            raise ctx.error(key, spec.label, f"specular meshes must be closed (watertight): {problem}")
        volume = mesh.signed_volume()
        if not volume > 0:  # inward-wound: inside and outside swap (the caustic came out 147× the reference's)
            raise ctx.error(key, spec.label, f"specular meshes must wind outward (counter-clockwise seen from "
                                             f"outside); this one encloses a signed volume of {volume:.3g} m³: "
                                             f"reverse every face's vertex order")
    return mesh


def _objects(ctx, key, value, build):
    if not isinstance(value, list):
        raise ctx.error(key, value, f"expected an array of tables [[{key}]]")
    return tuple(build(ctx, f"{key}[{i}]", item, i) for i, item in enumerate(value))


def _specular(ctx, key, value, index) -> SpecularObject:
    t = _Table(ctx, key, value)
    name = t.get("name", _string, f"specular{index}")
    transform = t.get("transform", _transform, Transform())
    mesh = t.get("mesh", lambda c, k, v: _mesh(c, k, v, transform))
    ior = t.get("ior", _ranged(1.0, 10.0), 1.5)
    absorption = t.get("absorption", _rgb(0.0, unit="1/m"), (0.0, 0.0, 0.0))
    t.finish()
    _load_checked(ctx, f"{key}.mesh", mesh, closed=True)
    return SpecularObject(name, mesh, ior, absorption)


def _diffuse(ctx, key, value, index) -> DiffuseSurface:
    t = _Table(ctx, key, value)
    name = t.get("name", _string, f"diffuse{index}")
    transform = t.get("transform", _transform, Transform())
    mesh = t.get("mesh", lambda c, k, v: _mesh(c, k, v, transform))
    albedo = t.get("albedo", _rgb(0.0, 1.0), (0.5, 0.5, 0.5))
    t.finish()
    _load_checked(ctx, f"{key}.mesh", mesh, closed=False)
    return DiffuseSurface(name, mesh, albedo)


# --- [animation] (scenes.animation) ------------------------------------------------

def _track_values(kind: str) -> Callable:
    return {"point": _vec3, "direction": _direction, "rgb": _rgb(0.0, unit="1/m or W/sr"),
            "angle": lambda c, k, v: (_view_angle(c, k, v),), "euler": _euler,
            "scale": lambda c, k, v: (_ranged(1.0 / COORDINATE_LIMIT, COORDINATE_LIMIT)(c, k, v),)}[kind]


def _track(ctx, key, value, index, scene: Scene) -> Track:
    t = _Table(ctx, key, value)
    path = t.get("path", _string)
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
    frames = tuple(_ranged(0.0, MAX_FRAMES)(ctx, f"{key}[{i}]", x) for i, x in enumerate(v))
    for i in range(1, len(frames)):
        if not frames[i] > frames[i - 1]:
            raise ctx.error(f"{key}[{i}]", v[i], f"expected frame numbers increasing (after {frames[i - 1]:g})")
    return frames


def _key_values(ctx, key, v, count: int, kind: str):
    if not isinstance(v, list) or len(v) != count:
        raise ctx.error(key, v, f"expected a list of {count} values, one per keyframe in `frame`")
    parse = _track_values(kind)
    return tuple(tuple(parse(ctx, f"{key}[{i}]", x)) for i, x in enumerate(v))


def _animation(ctx, value, scene: Scene) -> Animation:
    t = _Table(ctx, "animation", value)
    frames = t.get("frames", _integer(1, MAX_FRAMES))
    fps = t.get("fps", _ranged(*FPS_RANGE, unit="frames per second (what the video writers store)"), 24.0)
    tracks = t.get("track", lambda c, k, v: _objects(c, k, v, lambda c2, k2, v2, i: _track(c2, k2, v2, i, scene)), ())
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
    the light aims somewhere."""
    paths = {tr.path for tr in animation.tracks}
    moves = any(p.startswith(("camera.", "specular.")) for p in paths)
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
            _check_view(ctx, at.camera, where)
            for i, obj in enumerate(at.specular):  # in object space: no mesh is built per frame
                local = np.linalg.solve(obj.mesh.transform.matrix(), [*at.camera.position, 1.0])[:3]
                if winding_number(replace(obj.mesh, transform=Transform()).load(), local) > 0.5:
                    raise ctx.error("camera.position", list(at.camera.position),
                                    f"the camera must be outside every specular object (it is inside specular[{i}] "
                                    f"'{obj.name}'){where}")


# --- entry points -----------------------------------------------------------------

def parse_scene(data: dict, *, file: str | None = None, base_dir: str = ".", source: str | None = None) -> Scene:
    """Validate a parsed TOML document (a dict) and build the :class:`Scene`."""
    ctx = _Ctx(file, base_dir)
    t = _Table(ctx, "", data)
    stem = os.path.splitext(os.path.basename(file))[0] if file else "scene"
    name = t.get("name", _name, stem if _NAME.fullmatch(stem) else "scene")
    description = t.get("description", _string, "")
    camera = t.get("camera", _camera)
    light = t.get("light", _light)
    medium = t.get("medium", _medium, Medium())
    specular = t.get("specular", lambda c, k, v: _objects(c, k, v, _specular), ())
    diffuse = t.get("diffuse", lambda c, k, v: _objects(c, k, v, _diffuse), ())
    animation = t.get("animation", lambda c, k, v: v, None)
    t.finish()
    seen = {}
    for kind, objs in (("specular", specular), ("diffuse", diffuse)):
        for i, obj in enumerate(objs):
            if obj.name in seen:
                raise ctx.error(f"{kind}[{i}].name", obj.name,
                                f"names must be unique (already used by {seen[obj.name]})")
            seen[obj.name] = f"{kind}[{i}]"
    _check_camera_outside(ctx, camera, specular)
    scene = Scene(name=name, description=description, camera=camera, light=light, medium=medium,
                  specular=specular, diffuse=diffuse, source=source)
    if animation is not None:
        scene = replace(scene, animation=_animation(ctx, animation, scene))
    return scene


def _check_camera_outside(ctx, camera: Camera, specular) -> None:
    for i, obj in enumerate(specular):
        if winding_number(obj.mesh.load(), camera.position) > 0.5:
            raise ctx.error("camera.position", list(camera.position),
                            f"the camera must be outside every specular object "
                            f"(it is inside specular[{i}] '{obj.name}')")


def load_scene(path: str) -> Scene:
    """Read and validate a TOML scene file; raises :class:`SceneError` for any problem."""
    label = str(path)
    kind = special_file_kind(path)
    if kind:
        raise SceneError(label, None, None, f"is {kind}, expected a .toml scene file")
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise SceneError(label, None, None, "scene file does not exist") from None
    except IsADirectoryError:
        raise SceneError(label, None, None, "is a directory, expected a .toml scene file") from None
    except OSError as exc:
        raise SceneError(label, None, None, f"cannot read scene file ({exc.strerror or exc})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError(label, None, None, f"invalid TOML ({exc})") from None
    except RecursionError:
        raise SceneError(label, None, None, "invalid TOML (nested too deeply)") from None
    return parse_scene(data, file=label, base_dir=os.path.dirname(os.path.abspath(path)), source=os.path.abspath(path))
