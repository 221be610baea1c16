"""Scene → Mitsuba 3 scene description (dict for ``mi.load_dict``, or XML).

Same camera (pinhole, vertical fov, box filter), spot emitter, homogeneous
medium confined to the scene box (a null-BSDF cube whose interior is the fog,
see scenes.bounds), dielectric objects with absorbing interior media, diffuse
surfaces. Meshes are written as binary PLY files with our angle-weighted vertex
normals, so both renderers shade with identical normals.
"""

from __future__ import annotations

import hashlib
import os
from xml.sax.saxutils import quoteattr

import numpy as np

from scenes.bounds import medium_bounds
from scenes.storage import atomic_path, cache_dir

FOG_ID = "fog"


def write_ply(path: str, mesh) -> None:
    """Binary little-endian PLY with positions, vertex normals and triangles (atomic)."""
    normals = mesh.vertex_normals()
    v = np.zeros(len(mesh.vertices), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                             ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")])
    for k, name in enumerate("xyz"):
        v[name] = mesh.vertices[:, k]
        v["n" + name] = normals[:, k]
    f = np.zeros(len(mesh.faces), dtype=[("n", "u1"), ("i", "<i4", 3)])
    f["n"] = 3
    f["i"] = mesh.faces
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\n"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(header.encode("ascii"))
            fh.write(v.tobytes())
            fh.write(f.tobytes())


def mesh_file(mesh, folder: str) -> str:
    """PLY of ``mesh`` in ``folder``, named by a hash of its content (written once)."""
    digest = hashlib.sha256(mesh.vertices.tobytes() + mesh.faces.tobytes()).hexdigest()[:20]
    path = os.path.join(folder, f"mesh-{digest}.ply")
    if not os.path.exists(path):
        write_ply(path, mesh)
    return path


def _look_at(mi, origin, target, up):
    return mi.ScalarTransform4f().look_at(origin=list(map(float, origin)), target=list(map(float, target)),
                                          up=list(map(float, up)))


def _rgb(value):
    return {"type": "rgb", "value": [float(x) for x in value]}


def _homogeneous(sigma_t, albedo, phase=None) -> dict:
    """Homogeneous medium; Mitsuba's RGB values must lie in [0, 1], so sigma_t is
    normalised by its largest channel, which goes into ``scale``."""
    sigma_t = np.asarray(sigma_t, float)
    scale = float(sigma_t.max()) if sigma_t.max() > 0 else 1.0
    d = {"type": "homogeneous", "albedo": _rgb(albedo), "sigma_t": _rgb(sigma_t / scale), "scale": scale}
    if phase:
        d["phase"] = phase
    return d


def spot_to_world(mi, light):
    pos = np.asarray(light.position, float)
    axis = np.asarray(light.direction, float)
    up = [0.0, 1.0, 0.0] if abs(axis[1]) < 0.99 else [1.0, 0.0, 0.0]
    return _look_at(mi, pos, pos + axis, up)


def to_mitsuba(scene, *, integrator: dict | None = None, spp: int = 16, mesh_dir: str | None = None,
               medium_box: bool = True) -> dict:
    """Mitsuba scene dict of ``scene``. ``integrator`` defaults to volpath; ``mesh_dir``
    (default: the cache) receives the PLY files."""
    from .mi_setup import mitsuba

    mi = mitsuba()
    mesh_dir = mesh_dir or cache_dir("mitsuba-meshes")
    cam, light, medium = scene.camera, scene.light, scene.medium
    has_fog = not medium.is_vacuum
    fog = None
    if has_fog:
        sigma_t = np.asarray(medium.sigma_t, float)
        albedo = np.divide(medium.sigma_s, sigma_t, out=np.zeros(3), where=sigma_t > 0)
        phase = {"type": "hg", "g": float(medium.phase.g)} if medium.phase.kind == "hg" else {"type": "isotropic"}
        fog = _homogeneous(sigma_t, albedo, phase)
    d = {
        "type": "scene",
        "integrator": integrator or {"type": "volpath", "max_depth": 2},
        "sensor": {
            "type": "perspective", "fov": float(cam.fov_y), "fov_axis": "y",
            "near_clip": 1e-3, "far_clip": 1e4,
            "to_world": _look_at(mi, cam.position, cam.target, cam.up),
            "film": {"type": "hdrfilm", "width": int(cam.width), "height": int(cam.height),
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp)},
        },
        "light": {"type": "spot", "intensity": _rgb(light.intensity), "cutoff_angle": float(light.cutoff_angle),
                  "beam_width": float(light.beam_width), "to_world": spot_to_world(mi, light)},
    }
    if has_fog:
        d[FOG_ID] = fog
        d["sensor"]["medium"] = {"type": "ref", "id": FOG_ID}
        d["light"]["medium"] = {"type": "ref", "id": FOG_ID}
        if medium_box:
            lo, hi = medium_bounds(scene)
            center, half = (lo + hi) / 2, (hi - lo) / 2
            d["medium_box"] = {"type": "cube", "bsdf": {"type": "null"}, "interior": {"type": "ref", "id": FOG_ID},
                               "to_world": mi.ScalarTransform4f().translate(center.tolist()).scale(half.tolist())}
    for i, obj in enumerate(scene.specular):
        shape = {"type": "ply", "filename": mesh_file(obj.mesh.load(), mesh_dir), "face_normals": False,
                 "bsdf": {"type": "dielectric", "int_ior": float(obj.ior), "ext_ior": 1.0}}
        if any(obj.absorption):
            shape["interior"] = _homogeneous(obj.absorption, (0.0, 0.0, 0.0))
        if has_fog:
            shape["exterior"] = {"type": "ref", "id": FOG_ID}
        d[f"specular_{i}"] = shape
    for i, obj in enumerate(scene.diffuse):
        d[f"diffuse_{i}"] = {"type": "ply", "filename": mesh_file(obj.mesh.load(), mesh_dir), "face_normals": False,
                             "bsdf": {"type": "twosided", "material": {"type": "diffuse",
                                                                        "reflectance": _rgb(obj.albedo)}}}
    return d


def export_xml(scene, path: str) -> None:
    """Write a Mitsuba 3 XML scene (volpath) with its PLY meshes next to it (atomic)."""
    folder = os.path.dirname(os.path.abspath(path))
    mesh_dir = os.path.join(folder, os.path.splitext(os.path.basename(path))[0] + "_meshes")
    os.makedirs(mesh_dir, exist_ok=True)
    d = to_mitsuba(scene, mesh_dir=mesh_dir)
    lines = ['<scene version="3.0.0">']
    lines += _xml_object("integrator", d["integrator"], 1, folder)
    if FOG_ID in d:
        lines += _xml_object("medium", d[FOG_ID], 1, folder, name_id=FOG_ID)
    lines += _xml_object("sensor", d["sensor"], 1, folder)
    lines += _xml_object("emitter", d["light"], 1, folder)
    for key, value in d.items():
        if key.startswith(("specular_", "diffuse_", "medium_box")):
            lines += _xml_object("shape", value, 1, folder)
    lines.append("</scene>")
    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            fh.write("\n".join(lines) + "\n")


_TAGS = {"bsdf": "bsdf", "film": "film", "rfilter": "rfilter", "sampler": "sampler", "phase": "phase",
         "interior": "medium", "exterior": "medium", "medium": "medium", "material": "bsdf"}


def _xml_object(tag, obj, depth, folder, name_id=None):
    pad = "    " * depth
    attrs = f' type="{obj["type"]}"' if obj.get("type") not in (None, "ref") else ""
    if obj.get("type") == "ref":
        return [f'{pad}<ref id="{obj["id"]}"/>']
    if name_id:
        attrs += f' id="{name_id}"'
    lines = [f"{pad}<{tag}{attrs}>"]
    for key, value in obj.items():
        if key == "type":
            continue
        inner = pad + "    "
        if isinstance(value, dict) and value.get("type") == "ref":
            name = f' name="{key}"' if key in ("interior", "exterior") else ""
            lines.append(f'{inner}<ref{name} id="{value["id"]}"/>')
        elif isinstance(value, dict) and value.get("type") == "rgb":
            lines.append(f'{inner}<rgb name="{key}" value="{", ".join(repr(float(x)) for x in value["value"])}"/>')
        elif isinstance(value, dict):
            sub = _xml_object(_TAGS.get(key, key), value, depth + 1, folder)
            if key in ("interior", "exterior"):
                sub[0] = sub[0].replace("<medium", f'<medium name="{key}"', 1)
            lines += sub
        elif key == "to_world":
            m = np.asarray(value.matrix, dtype=float).reshape(4, 4)
            lines.append(f'{inner}<transform name="to_world"><matrix value="{" ".join(repr(float(x)) for x in m.ravel())}"/></transform>')
        elif isinstance(value, bool):
            lines.append(f'{inner}<boolean name="{key}" value="{str(value).lower()}"/>')
        elif isinstance(value, int):
            lines.append(f'{inner}<integer name="{key}" value="{value}"/>')
        elif isinstance(value, float):
            lines.append(f'{inner}<float name="{key}" value="{value!r}"/>')
        elif isinstance(value, str):
            if key == "filename":
                value = os.path.relpath(value, folder)
            lines.append(f"{inner}<string name={quoteattr(key)} value={quoteattr(value)}/>")
    lines.append(f"{pad}</{tag}>")
    return lines
