"""glTF 2.0 export of a scene, so that a real-time engine can load it (docs/howto/other-renderer.md).

What goes where:

- **meshes**: every specular object and diffuse surface in object space (its mesh
  without its placement), float32 POSITION (with min/max) and NORMAL (our angle-weighted
  vertex normals, unit), uint32 indices, counter-clockwise front faces as ours. One
  node per object, named after it, with TRS: translation, rotation (quaternion x, y, z,
  w of :meth:`Transform.matrix`'s rotation, Euler x then y then z) and scale [s, s, s].
  glTF and we are both right-handed, +Y up, metres: no axis change.
- **the spot light**: ``KHR_lights_punctual`` type ``spot`` on a node at the light's
  position whose −Z is the light's direction; ``outerConeAngle`` = cutoff_angle,
  ``innerConeAngle`` = beam_width (radians; :data:`CONE_GAP` below the outer angle at
  most, as glTF wants inner < outer); ``color`` × ``intensity`` = the radiant intensity
  on the axis in **W/sr** (radiometric, not candela: no 683 lm/W factor). glTF's smooth
  falloff differs from Mitsuba's ``spot``: the light's ``extras`` hold the exact values
  and profile.
- **glass**: baseColor white, metallic 0, roughness 0, ``KHR_materials_transmission``
  (1), ``KHR_materials_ior`` and ``KHR_materials_volume`` (attenuation from the interior
  absorption sigma: attenuationDistance 1 m, attenuationColor exp(−sigma·1 m); none
  when sigma = 0).
- **diffuse**: baseColor = albedo, metallic 0, roughness 1, double-sided.
- **the camera**: perspective, yfov = fov_y, aspectRatio = width/height, znear
  :data:`ZNEAR`, no zfar (infinite), on a node looking from position to target (−Z)
  with up (+Y).
- **scene extras** (key ``"volcaustics"``): what glTF cannot express: the medium,
  the image (size, box pixel filter, radiance units), the layers an image holds, the
  single-scattering model, the inside/outside-glass rule, units and conventions.

Only the scene at rest is exported: an ``[animation]`` is not (the extras say so).
``scenes`` is the bottom of the data flow: nothing here imports a renderer.
"""

from __future__ import annotations

import dataclasses
import math
import os
import urllib.parse

import numpy as np

from volcaustics.infra.storage import atomic_set, atomic_write_bytes

from .bounds import MARGIN, medium_bounds
from .formats import COLOUR_LAYERS, LAYER_MEANINGS, MASK_LAYER
from .model import Transform

GENERATOR = "volcaustics"
EXTRAS_KEY = "volcaustics"
ZNEAR = 0.01     # m: the camera's near plane (glTF requires one; ours is a pinhole without)
CONE_GAP = 1e-4  # rad: innerConeAngle at least this far below outerConeAngle (glTF: inner < outer), so that
                 # cos(inner) > cos(outer) survives float32 (docs/decisions.md, "glTF export")
FORMATS = (".glb", ".gltf")

# glTF constants (glTF 2.0 spec, 3.6 and 3.7)
_FLOAT, _UINT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963

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


def export_gltf(scene, path: str) -> dict:
    """Write ``scene`` (at rest) as glTF 2.0: ``path`` ending in ``.glb`` (one binary
    file) or ``.gltf`` (JSON, its buffer in a ``.bin`` of the same stem beside it);
    atomically (a ``.gltf`` and its ``.bin`` as one unit). Returns what was written:
    ``files`` (paths), ``nodes``, ``meshes``, ``triangles``, ``vertices``, ``materials``,
    ``bytes`` (the binary buffer), ``inner_cone_adjusted``. ValueError for another
    extension."""
    ext = next((e for e in FORMATS if path.lower().endswith(e) and len(os.path.basename(path)) > len(e)), None)
    if ext is None:
        raise ValueError(f"{path}: expected a file name ending in .glb (one binary file) or .gltf (with a .bin "
                         f"beside it)")
    gltf, blob = gltf_document(scene)
    if ext == ".glb":
        gltf.set_binary_blob(blob)
        atomic_write_bytes(path, b"".join(gltf.save_to_bytes()))
        files = [path]
    else:
        bin_path = path[: -len(ext)] + ".bin"
        gltf.buffers[0].uri = urllib.parse.quote(os.path.basename(bin_path))  # a URI: "a b#1.bin" → "a%20b%231.bin"
        with atomic_set([bin_path, path]) as (bin_tmp, gltf_tmp):  # the .gltf (which names the .bin) goes last
            with open(bin_tmp, "wb") as fh:
                fh.write(blob)
            with open(gltf_tmp, "w", encoding="utf-8") as fh:
                fh.write(gltf.gltf_to_json())
        files = [path, bin_path]
    return {"files": files, **document_counts(gltf), "bytes": len(blob)}


def gltf_document(scene):
    """(pygltflib.GLTF2, buffer bytes) of ``scene`` at rest (module docstring); the
    document's one buffer has no uri yet (a .glb's own chunk, or a .bin to name)."""
    from pygltflib import GLTF2, Asset, Buffer, Node
    from pygltflib import Scene as GltfScene

    gltf = GLTF2(asset=Asset(generator=GENERATOR, version="2.0"))
    blob = _Blob(gltf)
    nodes = []
    for obj in scene.specular:
        nodes.append(_object_node(gltf, blob, obj, _glass_material(obj, _object_space(obj))))
    for obj in scene.diffuse:
        nodes.append(_object_node(gltf, blob, obj, _diffuse_material(obj)))
    light = _spot_light(scene.light)
    gltf.extensions["KHR_lights_punctual"] = {"lights": [light]}
    nodes.append(Node(name="spot_light", translation=_floats(scene.light.position),
                      rotation=quaternion(_look_rotation(scene.light.direction, _up_hint(scene.light.direction))),
                      extensions={"KHR_lights_punctual": {"light": 0}}))
    gltf.cameras.append(_camera(scene.camera))
    nodes.append(Node(name="camera", camera=0, translation=_floats(scene.camera.position),
                      rotation=quaternion(_look_rotation(scene.camera.forward, scene.camera.up))))
    gltf.nodes = nodes
    gltf.scenes = [GltfScene(name=scene.name, nodes=list(range(len(nodes))),
                             extras={EXTRAS_KEY: scene_extras(scene)})]
    gltf.scene = 0
    used = ["KHR_lights_punctual"]
    if scene.specular:
        used += ["KHR_materials_ior", "KHR_materials_transmission", "KHR_materials_volume"]
    gltf.extensionsUsed = used
    gltf.buffers = [Buffer(byteLength=len(blob.data))]
    return gltf, bytes(blob.data)


def document_counts(gltf) -> dict:
    """What a glTF document holds, counted from it: nodes, meshes, triangles, vertices,
    materials, and whether the spot's innerConeAngle was moved below beam_width."""
    primitives = [p for mesh in gltf.meshes for p in mesh.primitives]
    lights = gltf.extensions.get("KHR_lights_punctual", {}).get("lights", [])
    return {"nodes": len(gltf.nodes), "meshes": len(gltf.meshes),
            "triangles": sum(gltf.accessors[p.indices].count // 3 for p in primitives),
            "vertices": sum(gltf.accessors[p.attributes.POSITION].count for p in primitives),
            "materials": len(gltf.materials),
            "inner_cone_adjusted": any("innerConeAngle_adjusted" in light.get("extras", {}).get(EXTRAS_KEY, {})
                                       for light in lights)}


# --- meshes ----------------------------------------------------------------------------

class _Blob:
    """The one binary buffer: a buffer view and an accessor per array (all 4-byte
    components, so every view starts aligned)."""

    def __init__(self, gltf):
        self.gltf = gltf
        self.data = bytearray()

    def add(self, array: np.ndarray, kind: str, component: int, target: int, with_bounds: bool) -> int:
        from pygltflib import Accessor, BufferView

        raw = np.ascontiguousarray(array).tobytes()
        self.gltf.bufferViews.append(BufferView(buffer=0, byteOffset=len(self.data), byteLength=len(raw),
                                                target=target))
        self.data += raw
        accessor = Accessor(bufferView=len(self.gltf.bufferViews) - 1, componentType=component, count=len(array),
                            type=kind)
        if with_bounds:  # from the stored float32 values: the validator compares them exactly
            accessor.min = [float(x) for x in array.min(axis=0)]
            accessor.max = [float(x) for x in array.max(axis=0)]
        self.gltf.accessors.append(accessor)
        return len(self.gltf.accessors) - 1


def _object_space(obj):
    """The object's :class:`~scenes.mesh.Mesh` without its placement (what a node places)."""
    return dataclasses.replace(obj.mesh, transform=Transform()).load()


def _object_node(gltf, blob: _Blob, obj, material):
    from pygltflib import Attributes, Mesh, Node, Primitive

    mesh = _object_space(obj)
    position = blob.add(mesh.vertices.astype(np.float32), "VEC3", _FLOAT, _ARRAY_BUFFER, True)
    normal = blob.add(unit_vertex_normals(mesh).astype(np.float32), "VEC3", _FLOAT, _ARRAY_BUFFER, False)
    indices = blob.add(mesh.faces.astype(np.uint32).reshape(-1), "SCALAR", _UINT, _ELEMENT_ARRAY_BUFFER, False)
    gltf.materials.append(material)
    gltf.meshes.append(Mesh(name=obj.name, primitives=[Primitive(
        attributes=Attributes(POSITION=position, NORMAL=normal), indices=indices,
        material=len(gltf.materials) - 1)]))
    t = obj.mesh.transform
    rotation = t.matrix()[:3, :3] / t.scale
    return Node(name=obj.name, mesh=len(gltf.meshes) - 1, translation=_floats(t.translate),
                rotation=quaternion(rotation), scale=[float(t.scale)] * 3)


def unit_vertex_normals(mesh) -> np.ndarray:
    """:meth:`Mesh.vertex_normals` (V×3 float64, unit), where a vertex touched only by
    zero-area faces (whose normal is 0: the skull stand-in has one) takes the mean of its
    neighbours' normals, or +Y: glTF wants every NORMAL unit, and such a vertex shades no
    area, so any unit vector renders the same."""
    normals = mesh.vertex_normals()
    zero = np.linalg.norm(normals, axis=1) < 0.5
    for v in np.flatnonzero(zero):
        ring = np.unique(mesh.faces[(mesh.faces == v).any(axis=1)])
        ring = ring[~zero[ring]]
        mean = normals[ring].sum(axis=0) if len(ring) else np.zeros(3)
        norm = np.linalg.norm(mean)
        normals[v] = mean / norm if norm > 1e-12 else (0.0, 1.0, 0.0)
    return normals


# --- materials -------------------------------------------------------------------------

def _glass_material(obj, mesh):
    from pygltflib import Material, PbrMetallicRoughness

    sigma = np.asarray(obj.absorption, np.float64)
    extent = np.ptp(mesh.vertices, axis=0)
    volume = {"thicknessFactor": float(extent[extent > 0].min()) if np.any(extent > 0) else 1.0}  # mesh space
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
            "absorption_per_m": _floats(obj.absorption),
            "absorption_model": "Beer-Lambert inside the glass: T = exp(-absorption_per_m * d), d in metres; "
                                "KHR_materials_volume: absorption = -ln(attenuationColor) / attenuationDistance",
            "thicknessFactor": "the mesh's smallest bounding-box extent in its own coordinates (glTF's unit for "
                               "it); not used by either of our renderers, which trace the closed mesh",
        }})


def _diffuse_material(obj):
    from pygltflib import Material, PbrMetallicRoughness

    return Material(
        name=obj.name, doubleSided=True,
        pbrMetallicRoughness=PbrMetallicRoughness(baseColorFactor=[*_floats(obj.albedo), 1.0],
                                                  metallicFactor=0.0, roughnessFactor=1.0),
        extras={EXTRAS_KEY: {"bsdf": "Lambertian, lit from either side", "albedo": _floats(obj.albedo)}})


# --- light and camera ------------------------------------------------------------------

def _spot_light(light) -> dict:
    """The KHR_lights_punctual light (a dict: the extension has no pygltflib class)."""
    intensity = np.asarray(light.intensity, np.float64)
    peak = float(intensity.max())
    outer = math.radians(light.cutoff_angle)
    beam = math.radians(light.beam_width)
    inner = max(0.0, min(beam, outer - CONE_GAP))
    extras = {
        "intensity_W_per_sr": _floats(intensity),
        "intensity_unit": "W/sr, radiant intensity on the axis (radiometric: not candela, no 683 lm/W factor); "
                          "glTF color * intensity is this value, color = intensity_W_per_sr / max",
        "position": _floats(light.position),
        "direction": _floats(light.direction),
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
    return {"type": "spot", "name": "spot_light", "color": _floats(intensity / peak), "intensity": peak,
            "spot": {"innerConeAngle": inner, "outerConeAngle": outer},
            "extras": {EXTRAS_KEY: extras}}


def _camera(camera):
    from pygltflib import Camera, Perspective

    return Camera(type="perspective", name="camera",
                  perspective=Perspective(yfov=math.radians(camera.fov_y), aspectRatio=camera.width / camera.height,
                                          znear=ZNEAR),
                  extras={EXTRAS_KEY: {
                      "model": "pinhole, vertical field of view (yfov), box pixel filter",
                      "fov_y_deg": float(camera.fov_y),
                      "position": _floats(camera.position),
                      "target": _floats(camera.target),
                      "up": _floats(camera.up),
                      "width": int(camera.width),
                      "height": int(camera.height),
                      "znear": "glTF requires a near plane; ours has none (a pinhole sees from 0)",
                  }})


def _look_rotation(forward, up) -> np.ndarray:
    """3×3 rotation whose −Z is ``forward`` and whose +Y is ``up`` made orthogonal to it
    (columns x, y, z: a camera's or a light's frame, as a look-at)."""
    f = np.asarray(forward, np.float64)
    f = f / np.linalg.norm(f)
    s = np.cross(f, np.asarray(up, np.float64))
    s /= np.linalg.norm(s)
    return np.column_stack([s, np.cross(s, f), -f])


def _up_hint(direction) -> tuple:
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

def scene_extras(scene) -> dict:
    """The scene's ``extras["volcaustics"]``: the facts of docs/conventions.md
    that glTF has no field for (glTF has no ratified participating-media extension)."""
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
            "kind": "homogeneous",
            "sigma_s": _floats(medium.sigma_s),
            "sigma_a": _floats(medium.sigma_a),
            "sigma_t": _floats(medium.sigma_t),
            "unit": "1/m, RGB",
            "phase": {"kind": medium.phase.kind, "g": float(medium.phase.g)},
            "extent": f"fills the scene outside the objects: the axis-aligned box [box_min, box_max] around every "
                      f"mesh, the light and the camera (margin {MARGIN:g} of its diagonal), less the glass "
                      f"interiors; vacuum outside the box",
            "box_min": _floats(lo),
            "box_max": _floats(hi),
            "vacuum": bool(medium.is_vacuum),
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


def _floats(values) -> list:
    return [float(x) for x in values]
