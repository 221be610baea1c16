"""The typed readers of a scene file's TOML values: numbers in ranges, integers, names,
RGB triples and directions, each raising a SceneError that names the file, the key, the
value and what is allowed (``scenes.loader`` builds the scene from them)."""

from __future__ import annotations

import math
import re
from typing import Any, Callable, TypeVar

from .errors import SceneError
from .model import Camera

_T = TypeVar("_T")
_REQUIRED = object()


class Context:
    """Where we are: the file label and the directory mesh paths are relative to."""

    def __init__(self, file: str | None, base_dir: str):
        self.file = file
        self.base_dir = base_dir

    def error(self, key: str | None, value: Any, allowed: str) -> SceneError:
        return SceneError(self.file, key, value, allowed)


class Table:
    """One TOML table: typed reads by key, then :meth:`finish` rejects unknown keys."""

    def __init__(self, ctx: Context, key: str, table: Any):
        if not isinstance(table, dict):
            raise ctx.error(key or "<top level>", table, "expected a table")
        self.ctx, self.key, self.table = ctx, key, table
        self.used: set[str] = set()

    def path(self, k: str) -> str:
        return f"{self.key}.{k}" if self.key else k

    def get(self, k: str, parse: Callable, default: Any = _REQUIRED) -> Any:
        self.used.add(k)
        if k not in self.table:
            if default is _REQUIRED:
                raise self.ctx.error(self.path(k), None, "missing required key")
            return default
        return parse(self.ctx, self.path(k), self.table[k])

    def finish(self) -> None:
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


def ranged(low: float | None = None, high: float | None = None, *, low_open: bool = False, high_open: bool = False,
           unit: str = "") -> Callable[[Context, str, Any], float]:
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


def integer_in(low: int, high: int) -> Callable[[Context, str, Any], int]:
    def parse(ctx, key, v):
        if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
            raise ctx.error(key, v, f"expected an integer in [{low}, {high}]")
        return int(v)

    return parse


def string_value(ctx: Context, key: str, v: Any) -> str:
    if not isinstance(v, str):
        raise ctx.error(key, v, "expected a string")
    return v


NAME_PATTERN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}")


def name_value(ctx: Context, key: str, v: Any) -> str:
    """A scene's name: it becomes a file name (previews, reports), so letters, digits,
    '_', '.', '-' only, not starting with '.' or '-', at most 64 characters."""
    v = string_value(ctx, key, v)
    if not NAME_PATTERN.fullmatch(v):
        raise ctx.error(key, v, "expected a name of letters, digits, '_', '.' and '-' (not starting with '.' or "
                                "'-', at most 64 characters): it becomes a file name")
    return v


_coordinate = ranged(-COORDINATE_LIMIT, COORDINATE_LIMIT, unit="m")
# The smallest angle (degrees) of a view or a spot cone: float32 resolves angles near 0
# through cos/acos only to ~0.02 degrees (sqrt(2 * 6e-8) rad); below it the reference's
# spot profile divides by zero and its camera rays degenerate (fov_y 1e-30 hung Mitsuba).
ANGLE_MIN = 0.1
# The widest spot cone (degrees): the light maps are a perspective projection of the cone,
# whose edge texels at 80° already subtend cos³ 80° = 0.5% of the centre's solid angle;
# at 89.99° the projection degenerates (the caustic came out as nothing, the reference not).
CONE_MAX = 80.0
cone_angle = ranged(ANGLE_MIN, CONE_MAX, unit="degrees")
# The widest view (degrees), the same bound on the camera's pinhole: a half-angle of 80°.
# The image plane spans ±tan(fov_y/2) (±1.1e5 at 179.999°), so beyond it the centre pixels
# hold nearly all the camera sees: the approximation rasterises one sample at each pixel's
# centre and missed it (all black at 179° and 179.999°) where the reference's box filter
# integrates it (64×48: caustic 0.010 at 179°, and at 170° direct 0.015 against approx's 0.091).
FOV_MAX = 2.0 * CONE_MAX
view_angle = ranged(ANGLE_MIN, FOV_MAX, unit="degrees")


def _three(element, what: str):
    """A parser of a list of 3 values, each parsed by ``element``; ``what`` names them."""
    def parse(ctx, key, v):
        if not isinstance(v, list) or len(v) != 3:
            raise ctx.error(key, v, f"expected a list of 3 {what}")
        return tuple(element(ctx, f"{key}[{i}]", x) for i, x in enumerate(v))

    return parse


vec3_value = _three(_coordinate, "numbers [x, y, z]")
# rotation angles, bounded like coordinates (float32 keeps 0.1° at 1e6°), named as angles
euler_value = _three(ranged(-COORDINATE_LIMIT, COORDINATE_LIMIT, unit="degrees"),
                "angles in degrees [about x, about y, about z]")


def rgb_value(low: float | None = 0.0, high: float | None = None,
              unit: str = "") -> Callable[[Context, str, Any], tuple[float, float, float]]:
    one = ranged(low, high, unit=unit)

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


def direction_value(ctx: Context, key: str, v: Any) -> tuple[float, ...]:
    d = vec3_value(ctx, key, v)
    n = math.sqrt(sum(x * x for x in d))
    if n < 1e-12:
        raise ctx.error(key, v, "expected a non-zero direction vector")
    return tuple(x / n for x in d)


# --- sections -------------------------------------------------------------------


def object_list(ctx: Context, key: str, value: Any,
                build: Callable[[Context, str, Any, int], _T]) -> tuple[_T, ...]:
    if not isinstance(value, list):
        raise ctx.error(key, value, f"expected an array of tables [[{key}]]")
    return tuple(build(ctx, f"{key}[{i}]", item, i) for i, item in enumerate(value))


def check_view(ctx: Context, cam: Camera, where: str = "") -> None:
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
