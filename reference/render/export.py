"""Scene → Mitsuba 3 scene (dict for ``mi.load_dict``, or XML).

What Mitsuba gets is described, as plain data, by ``reference.description``;
this module turns a description into Mitsuba's objects: transforms through
Mitsuba's ``ScalarTransform4f``, meshes into PLY files named by the SHA-256 of
their content (positions, normals, faces: a change of any of them writes a new
file, never reuses an old one), checked byte for byte whenever they are used.
"""

from __future__ import annotations

import os
import shutil
from types import ModuleType
from typing import TYPE_CHECKING, Any
from xml.sax.saxutils import quoteattr

import numpy as np

from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import atomic_path, atomic_write_bytes, cache_dir, cache_path, special_file_kind

from ..description import FOG_ID, Description, describe, ply_bytes, ply_digest

if TYPE_CHECKING:
    from volcaustics.scenes.mesh import Mesh
    from volcaustics.scenes.model import Scene

class ExportError(InputError):
    """An export whose outputs cannot be written where they go (the message names the path)."""


PLY_NAME_DIGITS = 32  # hex digits of the content hash in a PLY file name
MESH_FOLDER = "mitsuba-meshes"  # the cache's folder of PLY files


def ply_file(data: bytes, folder: str | None = None, digest: str | None = None, kind: str = "mesh") -> str:
    """Path of the file holding ``data`` in ``folder`` (default: the cache's
    MESH_FOLDER, which serves what it holds when read-only), named by its content hash
    (``mesh-HASH.ply``, or ``density-HASH.vol`` for ``kind`` ``"density"``);
    written (atomically) unless a file of exactly these bytes is there: one that is not
    (truncated, garbage, another mesh's bytes) is rewritten, never given to Mitsuba."""
    suffix = ".vol" if kind == "density" else ".ply"
    name = f"{kind}-{(digest or ply_digest(data))[:PLY_NAME_DIGITS]}{suffix}"
    path = os.path.join(folder or cache_path(MESH_FOLDER), name)
    if not _holds(path, data):
        path = os.path.join(folder or cache_dir(MESH_FOLDER), name)
        atomic_write_bytes(path, data)
    return path


def _holds(path: str, data: bytes) -> bool:
    """Whether the regular file ``path`` holds exactly ``data`` (a FIFO or device is never opened)."""
    if special_file_kind(path):
        return False
    try:
        with open(path, "rb") as fh:
            return fh.read(len(data) + 1) == data
    except OSError:
        return False


def mesh_file(mesh: Mesh, folder: str | None = None) -> str:
    """PLY of ``mesh`` (positions, vertex normals, faces) in ``folder`` (default: the
    cache), named by its content."""
    return ply_file(ply_bytes(mesh), folder)


def write_ply(path: str, mesh: Mesh) -> None:
    """Binary little-endian PLY with positions, vertex normals and triangles (atomic)."""
    atomic_write_bytes(path, ply_bytes(mesh))


def _transform(mi, ops):
    t = mi.ScalarTransform4f()
    for op, *vectors in ops:
        if op == "look_at":
            origin, target, up = vectors
            t = t.look_at(origin=origin, target=target, up=up)
        elif op in ("translate", "scale"):
            t = getattr(t, op)(vectors[0])
        else:
            raise ValueError(f"transform op {op!r}: expected look_at, translate or scale")
    return t


def load_scene(mi: ModuleType, description: Description) -> Any:
    """The Mitsuba scene of ``description``, its objects as they are: Mitsuba's load-time
    optimisation merges objects with identical BSDFs and media into one shape without an
    id, and the light tracer tells its shapes apart by id (``shapes.ShapeTable``): nine
    identical glass lenses had vanished from the caustic (the held-out lens_array)."""
    return mi.load_dict(mitsuba_dict(description), optimize=False)


def mitsuba_dict(description: Description, mesh_dir: str | None = None) -> dict:
    """The ``mi.load_dict`` input of a description; ``mesh_dir`` (default: the cache)
    receives the PLY files."""
    from ..mi_setup import mitsuba

    mi = mitsuba()

    def convert(node):
        if not isinstance(node, dict):
            return node
        if node.get("type") == "transform":
            return _transform(mi, node["ops"])
        out = {}
        for key, value in node.items():
            if key == "mesh" and node.get("type") == "ply":
                out["filename"] = ply_file(description.meshes[value], mesh_dir, value)
            elif key == "volume" and node.get("type") == "gridvolume":
                out["filename"] = ply_file(description.volumes[value], mesh_dir, value, kind="density")
            else:
                out[key] = convert(value)
        return out

    return convert(description.tree)


def to_mitsuba(scene: Scene, *, integrator: dict | None = None, spp: int = 16, mesh_dir: str | None = None,
               medium_box: bool = True) -> dict:
    """Mitsuba scene dict of ``scene`` (see reference.description). ``integrator``
    defaults to volpath; ``mesh_dir`` (default: the cache) receives the PLY files."""
    return mitsuba_dict(describe(scene, integrator=integrator, spp=spp, medium_box=medium_box), mesh_dir)


def mesh_folder(path: str) -> str:
    """The folder of the PLY meshes beside the XML file ``path``: ``OUT_meshes``."""
    return os.path.join(os.path.dirname(os.path.abspath(path)), os.path.splitext(os.path.basename(path))[0] + "_meshes")


def mesh_folder_problem(path: str) -> str | None:
    """Why the mesh folder of the XML file ``path`` cannot be written (None if it can): a
    file there, or a symbolic link (the meshes would be written through it, into the
    folder it names, and a dangling one failed with "File exists")."""
    mesh_dir = mesh_folder(path)
    if os.path.islink(mesh_dir):
        return (f"{mesh_dir} (where its meshes go) is a symbolic link (to {os.readlink(mesh_dir)}): the meshes "
                f"are not written through it; remove it or choose another name")
    if os.path.exists(mesh_dir) and not os.path.isdir(mesh_dir):
        return f"{mesh_dir} (where its meshes go) is a file: move it or choose another name"
    return None


def export_xml(scene: Scene, path: str) -> None:
    """Write a Mitsuba 3 XML scene (volpath) with its PLY meshes next to it, in ``OUT_meshes/``
    (atomic); raises :class:`ExportError` where that folder is a file or a symbolic link."""
    folder = os.path.dirname(os.path.abspath(path))
    mesh_dir = mesh_folder(path)
    problem = mesh_folder_problem(path)
    if problem is not None:
        raise ExportError(f"{path}: {problem}")
    created = not os.path.isdir(mesh_dir)
    os.makedirs(mesh_dir, exist_ok=True)
    try:
        _write_xml(scene, path, folder, mesh_dir)
    except BaseException:  # Ctrl-C or a failure: a mesh folder this call made goes with it
        if created:
            shutil.rmtree(mesh_dir, ignore_errors=True)
        raise


def _write_xml(scene, path: str, folder: str, mesh_dir: str) -> None:
    d = to_mitsuba(scene, mesh_dir=mesh_dir)
    film, sampler = d["sensor"]["film"], d["sensor"]["sampler"]
    lines = ['<scene version="3.0.0">',
             "    <!-- Exported by volcaustics. Stock Mitsuba integrators cannot render this scene's volume caustic:",
             "         its light reaches the medium only through glass from a delta (spot) light, which no camera",
             "         path can connect to. volcaustics renders it with its own light tracer "
             "(reference/integrators.py);",
             "         volpath below renders the fog and direct light. Override the defaults with",
             "         mitsuba.load_file(path, resx=..., resy=..., spp=...) or mitsuba -D resx=... -->"]
    defaults = {"resx": film["width"], "resy": film["height"], "spp": sampler["sample_count"]}
    lines += [f'    <default name="{name}" value="{value}"/>' for name, value in defaults.items()]
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


# values the XML takes from its <default>s (tag, key) → parameter name
PARAMETERS = {("film", "width"): "resx", ("film", "height"): "resy", ("sampler", "sample_count"): "spp"}
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
        elif isinstance(value, dict) and value.get("type") == "gridvolume":
            sub = _xml_object("volume", value, depth + 1, folder)
            sub[0] = sub[0].replace("<volume", f'<volume name="{key}"', 1)
            lines += sub
        elif isinstance(value, dict):
            sub = _xml_object(_TAGS.get(key, key), value, depth + 1, folder)
            if key in ("interior", "exterior"):
                sub[0] = sub[0].replace("<medium", f'<medium name="{key}"', 1)
            lines += sub
        elif key == "to_world":
            m = np.asarray(value.matrix, dtype=float).reshape(4, 4)
            matrix = " ".join(repr(float(x)) for x in m.ravel())
            lines.append(f'{inner}<transform name="to_world"><matrix value="{matrix}"/></transform>')
        elif isinstance(value, bool):
            lines.append(f'{inner}<boolean name="{key}" value="{str(value).lower()}"/>')
        elif isinstance(value, int):
            shown = f"${PARAMETERS[(tag, key)]}" if (tag, key) in PARAMETERS else value
            lines.append(f'{inner}<integer name="{key}" value="{shown}"/>')
        elif isinstance(value, float):
            lines.append(f'{inner}<float name="{key}" value="{value!r}"/>')
        elif isinstance(value, str):
            if key == "filename":
                value = os.path.relpath(value, folder)
            lines.append(f"{inner}<string name={quoteattr(key)} value={quoteattr(value)}/>")
    lines.append(f"{pad}</{tag}>")
    return lines
