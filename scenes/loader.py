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
    fov_y = 40                    # vertical field of view, degrees, 0.1 <= fov_y <= 160
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
    [medium.density]              # optional: heterogeneous, sigma_s and sigma_a scaled by rho(x)
    field = "height_fog"          # or "plume", "box" (scenes.density_fields), or path = "smoke.npy" / ".vol"
    scale_height = 0.4            # the field's parameters
    resolution = [32, 16, 32]     # cells along x, y, z (a field; a file has its own)
    box = { min = [-2, 0, -2], max = [2, 3, 2] }   # default: the medium box (a .npy file needs one)

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

import os
from dataclasses import replace
from functools import lru_cache

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from volcaustics.infra.storage import CacheError, file_sha256, special_file_kind

from .errors import SceneError
from .generators import GENERATORS
from .loader_animation import parse_animation
from .loader_density import check_density_covers, density_value
from .mesh import MeshReadError, closedness_problem, winding_number, within_box
from .mesh_cache import MESHES_KEPT
from .model import Camera, DiffuseSurface, Medium, MeshSpec, Phase, Scene, SpecularObject, SpotLight, Transform
from .toml_values import (
    ANGLE_MIN,
    COORDINATE_LIMIT,
    NAME_PATTERN,
    Context,
    Table,
    check_view,
    cone_angle,
    direction_value,
    euler_value,
    integer_in,
    name_value,
    object_list,
    ranged,
    rgb_value,
    string_value,
    vec3_value,
    view_angle,
)


def _camera(ctx, key, value) -> Camera:
    t = Table(ctx, key, value)
    cam = Camera(
        position=t.get("position", vec3_value),
        target=t.get("target", vec3_value),
        up=t.get("up", direction_value, (0.0, 1.0, 0.0)),
        fov_y=t.get("fov_y", view_angle),
        width=t.get("width", integer_in(1, 16384), 512),
        height=t.get("height", integer_in(1, 16384), 512),
    )
    t.finish()
    check_view(ctx, cam)
    return cam


def _light(ctx, key, value) -> SpotLight:
    t = Table(ctx, key, value)
    position = t.get("position", vec3_value)
    direction = t.get("direction", direction_value)
    intensity = t.get("intensity", rgb_value(0.0, unit="W/sr"))
    cutoff = t.get("cutoff_angle", cone_angle, 20.0)
    beam = t.get("beam_width", cone_angle, max(0.75 * cutoff, ANGLE_MIN))
    t.finish()
    if not max(intensity) > 0:
        raise ctx.error("light.intensity", list(intensity) if isinstance(intensity, tuple) else intensity,
                        "must be > 0 in some channel: a dark light lights nothing to render or measure")
    if beam > cutoff:
        raise ctx.error("light.beam_width", beam, f"must be <= light.cutoff_angle ({cutoff:g} degrees)")
    return SpotLight(position, direction, intensity, cutoff, beam)


def _medium(ctx, key, value) -> Medium:
    t = Table(ctx, key, value)
    sigma_s = t.get("sigma_s", rgb_value(0.0, unit="1/m"), (0.0, 0.0, 0.0))
    sigma_a = t.get("sigma_a", rgb_value(0.0, unit="1/m"), (0.0, 0.0, 0.0))
    kind = t.get("phase", string_value, "isotropic")
    if kind not in ("isotropic", "hg"):
        raise ctx.error("medium.phase", kind, 'expected "isotropic" or "hg"')
    g = t.get("g", ranged(-1, 1, low_open=True, high_open=True), None)
    density = t.get("density", density_value, None)
    t.finish()
    if g is not None and kind != "hg":
        raise ctx.error("medium.g", g, 'only allowed with phase = "hg"')
    return Medium(sigma_s, sigma_a, Phase(kind, 0.0 if g is None else g), density)


def _transform(ctx, key, value) -> Transform:
    t = Table(ctx, key, value)
    tr = Transform(
        translate=t.get("translate", vec3_value, (0.0, 0.0, 0.0)),
        rotate=t.get("rotate", euler_value, (0.0, 0.0, 0.0)),
        scale=t.get("scale", ranged(1.0 / COORDINATE_LIMIT, COORDINATE_LIMIT), 1.0),
    )
    t.finish()
    return tr


def _mesh(ctx, key, value, transform: Transform) -> MeshSpec:
    if isinstance(value, str):
        value = {"path": value}
    if not isinstance(value, dict):
        raise ctx.error(key, value, 'expected a mesh path ("file.ply") or a table { generator = "...", ... }')
    if "path" in value:
        t = Table(ctx, key, value)
        rel = t.get("path", string_value)
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
    t = Table(ctx, key, value)
    name = t.get("generator", string_value)
    if name not in GENERATORS:
        raise ctx.error(f"{key}.generator", name, f"expected one of: {', '.join(GENERATORS)}")
    params = {}
    for pname, spec in GENERATORS[name].params.items():
        parse = integer_in(int(spec.low), int(spec.high)) if spec.kind is int else ranged(spec.low, spec.high)
        params[pname] = t.get(pname, parse, spec.kind(spec.default))
    t.finish()
    return MeshSpec(generator=name, params=tuple(sorted(params.items())), transform=transform)


@lru_cache(maxsize=MESHES_KEPT)
def _closed_check(spec: MeshSpec) -> tuple[str | None, float]:
    """Why ``spec``'s mesh is not closed (None if it is) and its signed volume, once per spec
    as its mesh is loaded (``mesh_cache.load_mesh_spec``): a command resolves its scene
    several times, and Feline's 150k triangles took 0.2 s a check."""
    mesh = spec.load()
    return closedness_problem(mesh), mesh.signed_volume()


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
        problem, volume = _closed_check(spec)
        if problem is not None:
            raise ctx.error(key, spec.label, f"specular meshes must be closed (watertight): {problem}")
        if not volume > 0:  # inward-wound: inside and outside swap (the caustic came out 147× the reference's)
            raise ctx.error(key, spec.label, f"specular meshes must wind outward (counter-clockwise seen from "
                                             f"outside); this one encloses a signed volume of {volume:.3g} m³: "
                                             f"reverse every face's vertex order")
    return mesh


def _specular(ctx, key, value, index) -> SpecularObject:
    t = Table(ctx, key, value)
    name = t.get("name", string_value, f"specular{index}")
    transform = t.get("transform", _transform, Transform())
    mesh = t.get("mesh", lambda c, k, v: _mesh(c, k, v, transform))
    ior = t.get("ior", ranged(1.0, 10.0), 1.5)
    absorption = t.get("absorption", rgb_value(0.0, unit="1/m"), (0.0, 0.0, 0.0))
    t.finish()
    _load_checked(ctx, f"{key}.mesh", mesh, closed=True)
    return SpecularObject(name, mesh, ior, absorption)


def _diffuse(ctx, key, value, index) -> DiffuseSurface:
    t = Table(ctx, key, value)
    name = t.get("name", string_value, f"diffuse{index}")
    transform = t.get("transform", _transform, Transform())
    mesh = t.get("mesh", lambda c, k, v: _mesh(c, k, v, transform))
    albedo = t.get("albedo", rgb_value(0.0, 1.0), (0.5, 0.5, 0.5))
    t.finish()
    _load_checked(ctx, f"{key}.mesh", mesh, closed=False)
    return DiffuseSurface(name, mesh, albedo)


# --- [animation] (scenes.animation) ------------------------------------------------

def parse_scene(data: dict, *, file: str | None = None, base_dir: str = ".", source: str | None = None) -> Scene:
    """Validate a parsed TOML document (a dict) and build the :class:`Scene`."""
    ctx = Context(file, base_dir)
    t = Table(ctx, "", data)
    stem = os.path.splitext(os.path.basename(file))[0] if file else "scene"
    name = t.get("name", name_value, stem if NAME_PATTERN.fullmatch(stem) else "scene")
    description = t.get("description", string_value, "")
    t.get("order", integer_in(0, 1000), None)  # a built-in scene's place in the catalogue (scenes.catalogue)
    camera = t.get("camera", _camera)
    light = t.get("light", _light)
    medium = t.get("medium", _medium, Medium())
    specular = t.get("specular", lambda c, k, v: object_list(c, k, v, _specular), ())
    diffuse = t.get("diffuse", lambda c, k, v: object_list(c, k, v, _diffuse), ())
    animation = t.get("animation", lambda c, k, v: v, None)
    t.finish()
    seen: dict = {}
    for kind, objs in (("specular", specular), ("diffuse", diffuse)):
        for i, obj in enumerate(objs):
            if obj.name in seen:
                raise ctx.error(f"{kind}[{i}].name", obj.name,
                                f"names must be unique (already used by {seen[obj.name]})")
            seen[obj.name] = f"{kind}[{i}]"
    _check_outside_glass(ctx, camera, light, specular)
    scene = Scene(name=name, description=description, camera=camera, light=light, medium=medium,
                  specular=specular, diffuse=diffuse, source=source)
    check_density_covers(ctx, scene)
    if animation is not None:
        scene = replace(scene, animation=parse_animation(ctx, animation, scene))
    return scene


def _check_outside_glass(ctx, camera: Camera, light: SpotLight, specular) -> None:
    """The camera and the light are in the medium, outside every closed specular mesh: neither
    renderer starts a camera ray or a photon inside glass (a light inside the ball lit the floor
    in approx, direct sum 768, where the reference, correctly, had none)."""
    for i, obj in enumerate(specular):
        mesh = obj.mesh.load()
        for what, position in (("camera", camera.position), ("light", light.position)):
            if within_box(mesh, position) and winding_number(mesh, position) > 0.5:
                raise ctx.error(f"{what}.position", list(position),
                                f"the {what} must be outside every specular object "
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
