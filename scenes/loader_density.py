"""The ``[medium.density]`` table of a scene file (``scenes.loader`` reads the rest): a
procedural field (``scenes.density_fields``) or a grid file (``scenes.volume_files``), every
problem a SceneError naming the file, the key and the value: a missing or unreadable file, a
wrong shape, NaN, a negative density, a grid that does not cover the medium box."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from volcaustics.infra.storage import file_sha256, special_file_kind

from .bounds import medium_bounds
from .density import DEFAULT_RESOLUTION, Density, covers, grid_problem
from .density_fields import FIELDS
from .toml_values import Context, Table, integer_in, ranged, string_value, vec3_value
from .volume_files import GridFileError, read_grid

if TYPE_CHECKING:
    from .model import Scene


def _box(ctx, key, value) -> tuple:
    t = Table(ctx, key, value)
    lo, hi = t.get("min", vec3_value), t.get("max", vec3_value)
    t.finish()
    if not all(a < b for a, b in zip(lo, hi)):
        raise ctx.error(f"{key}.max", list(hi), f"must exceed {key}.min = {list(lo)} on every axis")
    return lo, hi


def density_value(ctx: Context, key: str, value: Any) -> Density:
    """The ``[medium.density]`` table: a field with its parameters and resolution, or a grid file."""
    t = Table(ctx, key, value)
    box = t.get("box", _box, None)
    if "path" in value:
        path, digest, values, stated = _grid_file(ctx, key, t.get("path", string_value))
        t.finish()
        if box is None and stated is None:
            raise ctx.error(f"{key}.box", None, "a .npy grid needs its box: box = { min = [x, y, z], max = [x, y, z] }")
        nz, ny, nx = values.shape
        return Density(path=path, content_hash=digest, resolution=(nx, ny, nz), box=box or stated)
    name = t.get("field", string_value)
    if name not in FIELDS:
        raise ctx.error(f"{key}.field", name, f"expected one of: {', '.join(FIELDS)} (or path = a .npy or .vol grid)")
    params = {}
    for pname, spec in FIELDS[name].params.items():
        parse = {"integer": integer_in(int(spec.low), int(spec.high)), "point": vec3_value,
                 "number": ranged(spec.low, spec.high)}[spec.kind]
        params[pname] = t.get(pname, parse, spec.default)
    resolution = t.get("resolution", _resolution, DEFAULT_RESOLUTION)
    t.finish()
    return Density(field=name, params=tuple(sorted(params.items())), resolution=resolution, box=box)


def _resolution(ctx, key, value) -> tuple[int, int, int]:
    if not isinstance(value, list) or len(value) != 3:
        raise ctx.error(key, value, "expected [nx, ny, nz]: cells along x, y and z")
    parse = integer_in(1, 512)
    return tuple(parse(ctx, f"{key}[{a}]", v) for a, v in enumerate(value))  # type: ignore[return-value]


def _grid_file(ctx, key, rel: str):
    """(absolute path, SHA-256, values, the box the file states) of a density grid file."""
    path = os.path.normpath(os.path.join(ctx.base_dir, os.path.expanduser(rel)))
    kind = special_file_kind(path)
    if kind:
        raise ctx.error(f"{key}.path", rel, f"a readable .npy or .vol grid ({path} is {kind})")
    try:
        digest = file_sha256(path)
        values, stated = read_grid(path)
    except OSError as exc:
        raise ctx.error(f"{key}.path", rel, f"a readable .npy or .vol grid ({path}: {exc.strerror or exc})") from None
    except GridFileError as exc:
        raise ctx.error(f"{key}.path", rel, f"{path}: {exc}") from None
    problem = grid_problem(values)
    if problem is not None:
        raise ctx.error(f"{key}.path", rel, f"{path}: a density grid holds {problem}")
    return path, digest, values, stated


def check_density_covers(ctx: Context, scene: Scene) -> None:
    """A density grid covers the medium box: outside its box ρ would be 0, a hole in the fog."""
    density = scene.medium.density
    if density is None or density.box is None:
        return
    lo, hi = medium_bounds(scene)
    if not covers(density.box, lo, hi):
        whose = "" if density.path is None else f" (the grid {density.path})"
        raise ctx.error("medium.density.box", [list(density.box[0]), list(density.box[1])],
                        f"a density grid{whose} must cover the medium box (min {[round(float(x), 4) for x in lo]}, "
                        f"max {[round(float(x), 4) for x in hi]}: the scene's meshes, light and camera); "
                        f"enlarge its box")
