"""The parts of a glTF scene that carry our physics: the glass and diffuse materials, the
spot light, the camera, node rotations, and the scene's extras (what glTF cannot express).
``gltf`` assembles them into a document."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.scenes.bounds import MARGIN, medium_bounds
from volcaustics.scenes.formats import COLOUR_LAYERS, LAYER_MEANINGS, MASK_LAYER
from volcaustics.scenes.medium_grid import density_grid

if TYPE_CHECKING:
    from numpy.typing import ArrayLike
    from pygltflib import Camera as GltfCamera
    from pygltflib import Material

    from volcaustics.scenes.mesh import Mesh
    from volcaustics.scenes.model import Camera, DiffuseSurface, Scene, SpecularObject, SpotLight

GENERATOR = "volcaustics"
EXTRAS_KEY = "volcaustics"
ZNEAR = 0.01     # m: the camera's near plane (glTF requires one; ours is a pinhole without)
CONE_GAP = 1e-4  # rad: innerConeAngle at least this far below outerConeAngle (glTF: inner < outer), so that
                 # cos(inner) > cos(outer) survives float32 (docs/decisions.md, "glTF export")
FORMATS = (".glb", ".gltf")

FALLOFF = ("Mitsuba 3 `spot` (src/emitters/spot.cpp, falloff_curve), which both renderers reproduce: "
           "I(theta) = intensity_W_per_sr * f(theta), theta the angle between the emitted direction and the "
           "spot axis (the node's -Z); f = 1 for theta <= beam_width, f = (cutoff_angle - theta) / "
           "(cutoff_angle - beam_width) for beam_width < theta < cutoff_angle (linear in the angle, not in its "
           "cosine), f = 0 for theta >= cutoff_angle. KHR_lights_punctual's own falloff (smooth, between "
           "cos(outerConeAngle) and cos(innerConeAngle)) differs: use this one to match our images. No range: "
           "inverse-square, as glTF's undefined range.")
INSIDE_RULE = ("after a specular interaction, a direction below the geometric surface (dot with the outward "
               "geometric normal (v1 - v0) x (v2 - v0) of the counter-clockwise triangle < 0) is inside the glass, "
               "whatever the shading (vertex) normal says")
SCATTERING_MODEL = ("single scattering (the paper's model): light scatters at most once in the medium on its way to "
                    "the camera; paths light -> glass -> medium -> glass -> camera (the medium seen through glass) "
                    "are outside both renderers (mask_specular)")


def glass_material(obj: SpecularObject, mesh: Mesh) -> Material:
    from pygltflib import Material, PbrMetallicRoughness

    sigma = np.asarray(obj.absorption, np.float64)
    extent = np.ptp(mesh.vertices, axis=0)
    volume: dict[str, float | list[float]] = {  # mesh space
        "thicknessFactor": float(extent[extent > 0].min()) if np.any(extent > 0) else 1.0}
    if np.any(sigma > 0):
        volume["attenuationDistance"] = 1.0  # m (world space): attenuationColor = exp(-sigma * 1 m)
        volume["attenuationColor"] = [float(x) for x in np.exp(-sigma)]
    return Material(
        name=obj.name, pbrMetallicRoughness=PbrMetallicRoughness(baseColorFactor=[1.0, 1.0, 1.0, 1.0],
                                                                 metallicFactor=0.0, roughnessFactor=0.0),
        extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                    "KHR_materials_ior": {"ior": float(obj.ior)},
                    "KHR_materials_volume": volume},
        extras={EXTRAS_KEY: {
            "bsdf": "smooth dielectric: Fresnel reflection and Snell refraction, outside ior 1",
            "ior": float(obj.ior),
            "absorption_per_m": float_list(obj.absorption),
            "absorption_model": "Beer-Lambert inside the glass: T = exp(-absorption_per_m * d), d in metres; "
                                "KHR_materials_volume: absorption = -ln(attenuationColor) / attenuationDistance",
            "thicknessFactor": "the mesh's smallest bounding-box extent in its own coordinates (glTF's unit for "
                               "it); not used by either of our renderers, which trace the closed mesh",
        }})


def diffuse_material(obj: DiffuseSurface) -> Material:
    from pygltflib import Material, PbrMetallicRoughness

    return Material(
        name=obj.name, doubleSided=True,
        pbrMetallicRoughness=PbrMetallicRoughness(baseColorFactor=[*float_list(obj.albedo), 1.0],
                                                  metallicFactor=0.0, roughnessFactor=1.0),
        extras={EXTRAS_KEY: {"bsdf": "Lambertian, lit from either side", "albedo": float_list(obj.albedo)}})


# --- light and camera ------------------------------------------------------------------

def spot_light(light: SpotLight) -> dict:
    """The KHR_lights_punctual light (a dict: the extension has no pygltflib class)."""
    intensity = np.asarray(light.intensity, np.float64)
    peak = float(intensity.max())
    outer = math.radians(light.cutoff_angle)
    beam = math.radians(light.beam_width)
    inner = max(0.0, min(beam, outer - CONE_GAP))
    extras = {
        "intensity_W_per_sr": float_list(intensity),
        "intensity_unit": "W/sr, radiant intensity on the axis (radiometric: not candela, no 683 lm/W factor); "
                          "glTF color * intensity is this value, color = intensity_W_per_sr / max",
        "position": float_list(light.position),
        "direction": float_list(light.direction),
        "cutoff_angle_deg": float(light.cutoff_angle),
        "cutoff_angle_rad": outer,
        "beam_width_deg": float(light.beam_width),
        "beam_width_rad": beam,
        "falloff": FALLOFF,
    }
    if inner != beam:
        extras["innerConeAngle_adjusted"] = (f"beam_width is {beam!r} rad; glTF requires innerConeAngle < "
                                             f"outerConeAngle, so innerConeAngle = outerConeAngle - {CONE_GAP:g} "
                                             f"rad")
    return {"type": "spot", "name": "spot_light", "color": float_list(intensity / peak), "intensity": peak,
            "spot": {"innerConeAngle": inner, "outerConeAngle": outer},
            "extras": {EXTRAS_KEY: extras}}


def camera_node(camera: Camera) -> GltfCamera:
    from pygltflib import Camera, Perspective

    return Camera(type="perspective", name="camera",
                  perspective=Perspective(yfov=math.radians(camera.fov_y), aspectRatio=camera.width / camera.height,
                                          znear=ZNEAR),
                  extras={EXTRAS_KEY: {
                      "model": "pinhole, vertical field of view (yfov), box pixel filter",
                      "fov_y_deg": float(camera.fov_y),
                      "position": float_list(camera.position),
                      "target": float_list(camera.target),
                      "up": float_list(camera.up),
                      "width": int(camera.width),
                      "height": int(camera.height),
                      "znear": "glTF requires a near plane; ours has none (a pinhole sees from 0)",
                  }})


def look_rotation(forward: ArrayLike, up: ArrayLike) -> np.ndarray:
    """3×3 rotation whose −Z is ``forward`` and whose +Y is ``up`` made orthogonal to it
    (columns x, y, z: a camera's or a light's frame, as a look-at)."""
    f = np.asarray(forward, np.float64)
    f = f / np.linalg.norm(f)
    s = np.cross(f, np.asarray(up, np.float64))
    s /= np.linalg.norm(s)
    return np.column_stack([s, np.cross(s, f), -f])


def up_hint(direction: ArrayLike) -> tuple:
    """The world axis least aligned with ``direction`` (a spot has no roll: any will do)."""
    axis = int(np.argmin(np.abs(np.asarray(direction, np.float64))))
    return tuple(1.0 if k == axis else 0.0 for k in range(3))


def quaternion(rotation: np.ndarray) -> list:
    """Unit quaternion [x, y, z, w] (glTF's order, w ≥ 0) of a 3×3 rotation matrix
    (float64), by scipy's ``Rotation`` (imported here: scipy costs a fraction of a second)."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(np.asarray(rotation, np.float64)).as_quat()
    return [float(x) for x in (-q if q[3] < 0 else q)]


# --- what glTF cannot express ----------------------------------------------------------

def density_extras(scene: Scene, density_file: str | None) -> dict:
    """A heterogeneous medium's density in the extras: its side file, the grid's convention
    and where it came from."""
    grid = density_grid(scene)
    assert grid is not None and scene.medium.density is not None
    return {
        "file": density_file,
        "format": "Mitsuba 3 .vol: float32, one channel, its bounding box in its header",
        "meaning": "sigma_s(x) = rho(x)·sigma_s and sigma_a(x) = rho(x)·sigma_a",
        "convention": "values[k, j, i] at the centre of cell (i, j, k) of the box; trilinear between centres, "
                      "clamped beyond the outermost ones, 0 outside the box (a GL 3D texture with linear "
                      "filtering and clamp-to-edge, Mitsuba's trilinear gridvolume)",
        "resolution": list(grid.resolution),
        "box_min": float_list(grid.lo),
        "box_max": float_list(grid.hi),
        "source": scene.medium.density.canonical(),
    }


def scene_extras(scene: Scene, density_file: str | None = None) -> dict:
    """The scene's ``extras["volcaustics"]``: the facts of docs/conventions.md
    that glTF has no field for (glTF has no ratified participating-media extension);
    ``density_file``: the side file holding a heterogeneous medium's density grid."""
    medium = scene.medium
    lo, hi = medium_bounds(scene)
    extras = {
        "scene": scene.name,
        "scene_hash": scene.scene_hash(),
        "description": scene.description,
        "convention": "glTF's own frame: right-handed, +Y up, metres (no axis change); the camera and the spot "
                      "light look along their node's -Z; angles in radians in glTF fields, *_deg in extras",
        "units": {"length": "m", "sigma": "1/m", "light intensity": "W/sr (radiometric)",
                  "radiance": "W·m⁻²·sr⁻¹, linear Rec.709 primaries"},
        "medium": {
            "kind": "homogeneous" if medium.density is None else "heterogeneous",
            "sigma_s": float_list(medium.sigma_s),
            "sigma_a": float_list(medium.sigma_a),
            "sigma_t": float_list(medium.sigma_t),
            "unit": "1/m, RGB",
            "phase": {"kind": medium.phase.kind, "g": float(medium.phase.g)},
            "extent": f"fills the scene outside the objects: the axis-aligned box [box_min, box_max] around every "
                      f"mesh, the light and the camera (margin {MARGIN:g} of its diagonal), less the glass "
                      f"interiors; vacuum outside the box",
            "box_min": float_list(lo),
            "box_max": float_list(hi),
            "vacuum": bool(medium.is_vacuum),
            **({} if medium.density is None else {"density": density_extras(scene, density_file)}),
        },
        "image": {
            "width": int(scene.camera.width),
            "height": int(scene.camera.height),
            "pixel_filter": "box, one sample = one pixel footprint",
            "radiance_units": "W·m⁻²·sr⁻¹, linear Rec.709",
            "rows": "row 0 at the top",
        },
        "layers": {name: LAYER_MEANINGS[name] for name in (*COLOUR_LAYERS, MASK_LAYER)},
        "scattering_model": SCATTERING_MODEL,
        "inside_glass_rule": INSIDE_RULE,
    }
    if scene.animation is not None:
        extras["animation"] = ("not exported: this file is the scene at rest; the scene file's [animation] "
                               "(keyframed light, medium, camera and object transforms) stays in the TOML")
    return extras


def float_list(values: Iterable[float]) -> list:
    return [float(x) for x in values]
