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
- **a heterogeneous medium's density**: glTF has no volume either, so its grid is a
  side file, ``STEM_density.vol`` (Mitsuba's format, written with the document as one
  unit), which the extras' ``medium.density`` names with the grid's convention.

Only the scene at rest is exported: an ``[animation]`` is not (the extras say so).
It lives with the files the commands write (``volcaustics export``): an interchange format
for other programs, not part of the scene model, and it needs no renderer.
"""

from __future__ import annotations

import dataclasses
import os
import urllib.parse
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.infra.storage import atomic_set
from volcaustics.scenes.medium_grid import density_grid
from volcaustics.scenes.model import Transform
from volcaustics.scenes.volume_files import vol_bytes

from .gltf_parts import (
    EXTRAS_KEY,
    FORMATS,
    GENERATOR,
    camera_node,
    diffuse_material,
    float_list,
    glass_material,
    look_rotation,
    quaternion,
    scene_extras,
    spot_light,
    up_hint,
)

if TYPE_CHECKING:
    from pygltflib import GLTF2

    from volcaustics.scenes.mesh import Mesh
    from volcaustics.scenes.model import Scene

# glTF constants (glTF 2.0 spec, 3.6 and 3.7)
_FLOAT, _UINT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
DENSITY_SUFFIX = "_density.vol"  # a heterogeneous medium's grid, beside the document


def export_gltf(scene: Scene, path: str) -> dict:
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
    density = density_sidecar(scene, path[: -len(ext)] + DENSITY_SUFFIX)
    gltf, blob = gltf_document(scene, None if density is None else os.path.basename(density[0]))
    sidecars = [density] if density is not None else []
    if ext == ".glb":
        gltf.set_binary_blob(blob)
        parts = [*sidecars, (path, b"".join(gltf.save_to_bytes()))]
    else:
        bin_path = path[: -len(ext)] + ".bin"
        gltf.buffers[0].uri = urllib.parse.quote(os.path.basename(bin_path))  # a URI: "a b#1.bin" → "a%20b%231.bin"
        parts = [(bin_path, blob), *sidecars, (path, gltf.gltf_to_json().encode("utf-8"))]
    with atomic_set([p for p, _ in parts]) as temporaries:  # the document (which names the others) goes last
        for tmp, (_, data) in zip(temporaries, parts):
            with open(tmp, "wb") as fh:
                fh.write(data)
    files = [parts[-1][0], *(p for p, _ in parts[:-1])]
    return {"files": files, **document_counts(gltf), "bytes": len(blob)}


def density_sidecar(scene: Scene, path: str) -> tuple[str, bytes] | None:
    """(``path``, the bytes of a Mitsuba ``.vol`` of the medium's density grid) for a
    heterogeneous medium, None for a homogeneous one: glTF has no field for a volume, so
    the grid travels beside the document and its extras name it."""
    grid = density_grid(scene)
    if grid is None:
        return None
    return path, vol_bytes(grid.values, grid.lo, grid.hi)


def gltf_document(scene: Scene, density_file: str | None = None) -> tuple[GLTF2, bytes]:
    """(pygltflib.GLTF2, buffer bytes) of ``scene`` at rest (module docstring); the
    document's one buffer has no uri yet (a .glb's own chunk, or a .bin to name);
    ``density_file``: the name of the density grid's side file, for the extras."""
    from pygltflib import GLTF2, Asset, Buffer, Node
    from pygltflib import Scene as GltfScene

    gltf = GLTF2(asset=Asset(generator=GENERATOR, version="2.0"))
    blob = _Blob(gltf)
    nodes = []
    for obj in scene.specular:
        nodes.append(_object_node(gltf, blob, obj, glass_material(obj, _object_space(obj))))
    for surface in scene.diffuse:
        nodes.append(_object_node(gltf, blob, surface, diffuse_material(surface)))
    light = spot_light(scene.light)
    gltf.extensions["KHR_lights_punctual"] = {"lights": [light]}
    nodes.append(Node(name="spot_light", translation=float_list(scene.light.position),
                      rotation=quaternion(look_rotation(scene.light.direction, up_hint(scene.light.direction))),
                      extensions={"KHR_lights_punctual": {"light": 0}}))
    gltf.cameras.append(camera_node(scene.camera))
    nodes.append(Node(name="camera", camera=0, translation=float_list(scene.camera.position),
                      rotation=quaternion(look_rotation(scene.camera.forward, scene.camera.up))))
    gltf.nodes = nodes
    gltf.scenes = [GltfScene(name=scene.name, nodes=list(range(len(nodes))),
                             extras={EXTRAS_KEY: scene_extras(scene, density_file)})]
    gltf.scene = 0
    used = ["KHR_lights_punctual"]
    if scene.specular:
        used += ["KHR_materials_ior", "KHR_materials_transmission", "KHR_materials_volume"]
    gltf.extensionsUsed = used
    gltf.buffers = [Buffer(byteLength=len(blob.data))]
    return gltf, bytes(blob.data)


def document_counts(gltf: GLTF2) -> dict:
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
    return Node(name=obj.name, mesh=len(gltf.meshes) - 1, translation=float_list(t.translate),
                rotation=quaternion(rotation), scale=[float(t.scale)] * 3)


def unit_vertex_normals(mesh: Mesh) -> np.ndarray:
    """:meth:`Mesh.vertex_normals` (V×3 float64, unit), where a vertex touched only by
    zero-area faces (whose normal is 0: the skull stand-in has one) takes the mean of its
    neighbours' normals, or +Y: glTF wants every NORMAL unit, and such a vertex shades no
    area, so any unit vector renders the same."""
    normals = mesh.vertex_normals().copy()  # the mesh's own are read-only
    zero = np.linalg.norm(normals, axis=1) < 0.5
    for v in np.flatnonzero(zero):
        ring = np.unique(mesh.faces[(mesh.faces == v).any(axis=1)])
        ring = ring[~zero[ring]]
        mean = normals[ring].sum(axis=0) if len(ring) else np.zeros(3)
        norm = np.linalg.norm(mean)
        normals[v] = mean / norm if norm > 1e-12 else (0.0, 1.0, 0.0)
    return normals


# --- materials -------------------------------------------------------------------------
