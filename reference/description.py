"""A scene as Mitsuba will load it, as plain data: the exact input of a reference render.

:func:`describe` builds the dict that ``mi.load_dict`` receives
(``reference.render.export.mitsuba_dict`` converts it) with two stand-ins that keep it
plain, hashable data and need no Mitsuba import:

* a transform is ``{"type": "transform", "ops": [[op, *vectors], ...]}``, applied
  in order with Mitsuba's own ``ScalarTransform4f`` (``look_at`` origin, target,
  up; ``translate``; ``scale``), so the render is what Mitsuba's look-at gives;
* a mesh is ``{"type": "ply", "mesh": digest}``, the SHA-256 of the PLY file's
  bytes (positions, our vertex normals, faces), and ``Description.meshes`` maps
  the digest to those bytes;
* a heterogeneous medium's extinction is ``{"type": "gridvolume", "volume": digest}``,
  the SHA-256 of a ``.vol`` file's bytes (ρ·σt / scale, three channels, over the density
  grid's box: ``scenes.density``), which ``Description.volumes`` maps to those bytes.

The reference cache key hashes this description, so whatever changes Mitsuba's
input — the medium box (scenes.bounds), the vertex normals (scenes.mesh), the
exporter — changes the key.

Same camera (pinhole, vertical fov, box filter), spot emitter, homogeneous (or
heterogeneous: Mitsuba's ``heterogeneous`` with a trilinear ``gridvolume``, the grid's own
convention) medium confined to the scene box (a null-BSDF cube whose interior is the fog,
see scenes.bounds), dielectric objects with absorbing interior media, diffuse
surfaces. Meshes carry our angle-weighted vertex normals, so both renderers shade
with identical normals.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from volcaustics.scenes.bounds import medium_bounds
from volcaustics.scenes.medium_grid import density_grid
from volcaustics.scenes.volume_files import vol_bytes

if TYPE_CHECKING:
    from volcaustics.scenes.mesh import Mesh
    from volcaustics.scenes.model import Scene, SpotLight

FOG_ID = "fog"


@dataclass(frozen=True)
class Description:
    """tree: the Mitsuba scene dict with transform and mesh stand-ins (module docstring).
    meshes: PLY digest → PLY file bytes, for every mesh the tree names."""

    tree: dict
    meshes: dict = field(default_factory=dict)
    volumes: dict = field(default_factory=dict)

    def json(self) -> str:
        """Canonical JSON of the tree (sorted keys, shortest round-trip floats)."""
        return json.dumps(self.tree, sort_keys=True, separators=(",", ":"), allow_nan=False)


def ply_bytes(mesh: Mesh) -> bytes:
    """Binary little-endian PLY: float32 positions and vertex normals, int32 triangles."""
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
    return header.encode("ascii") + v.tobytes() + f.tobytes()


def ply_digest(data: bytes) -> str:
    """SHA-256 (hex) of PLY bytes: a mesh's name in descriptions and file names."""
    return hashlib.sha256(data).hexdigest()


def _vec(v) -> list:
    return [float(x) for x in v]


def look_at(origin: Iterable[float], target: Iterable[float], up: Iterable[float]) -> dict:
    return {"type": "transform", "ops": [["look_at", _vec(origin), _vec(target), _vec(up)]]}


def spot_to_world(light: SpotLight) -> dict:
    """The spot's frame: looking along its axis from its position."""
    pos = np.asarray(light.position, float)
    axis = np.asarray(light.direction, float)
    up = [0.0, 1.0, 0.0] if abs(axis[1]) < 0.99 else [1.0, 0.0, 0.0]
    return look_at(pos, pos + axis, up)


def _rgb(value):
    return {"type": "rgb", "value": _vec(value)}


def _homogeneous(sigma_t, albedo, phase=None) -> dict:
    """Homogeneous medium; Mitsuba's RGB values must lie in [0, 1], so sigma_t is
    normalised by its largest channel, which goes into ``scale``."""
    sigma_t = np.asarray(sigma_t, float)
    scale = float(sigma_t.max()) if sigma_t.max() > 0 else 1.0
    d = {"type": "homogeneous", "albedo": _rgb(albedo), "sigma_t": _rgb(sigma_t / scale), "scale": scale}
    if phase:
        d["phase"] = phase
    return d


def _heterogeneous(scene: Scene, sigma_t, albedo, phase, volumes: dict) -> dict:
    """Mitsuba's ``heterogeneous`` medium: extinction ρ(x)·sigma_t from a three-channel
    trilinear grid of ρ·sigma_t / scale (scale: sigma_t's largest channel), placed on the
    density grid's box; volumes receives the ``.vol`` bytes by digest."""
    grid = density_grid(scene)
    assert grid is not None
    sigma_t = np.asarray(sigma_t, float)
    scale = float(sigma_t.max())
    data = vol_bytes(grid.values[..., None] * (sigma_t / scale).astype(np.float32), grid.lo, grid.hi)
    digest = hashlib.sha256(data).hexdigest()
    volumes[digest] = data
    place = {"type": "transform", "ops": [["translate", _vec(grid.lo)], ["scale", _vec(grid.hi - grid.lo)]]}
    extinction = {"type": "gridvolume", "volume": digest, "filter_type": "trilinear", "to_world": place}
    return {"type": "heterogeneous", "albedo": _rgb(albedo), "sigma_t": extinction, "scale": scale, "phase": phase}


def describe(scene: Scene, *, integrator: dict | None = None, spp: int = 16, medium_box: bool = True) -> Description:
    """The Mitsuba scene of ``scene`` as plain data; ``integrator`` defaults to volpath."""
    meshes: dict[str, bytes] = {}
    volumes: dict[str, bytes] = {}

    def ply(mesh: Mesh) -> dict:
        data = ply_bytes(mesh)
        digest = ply_digest(data)
        meshes[digest] = data
        return {"type": "ply", "mesh": digest, "face_normals": False}

    cam, light, medium = scene.camera, scene.light, scene.medium
    has_fog = not medium.is_vacuum
    d: dict[str, Any] = {
        "type": "scene",
        "integrator": integrator or {"type": "volpath", "max_depth": 2},
        "sensor": {
            "type": "perspective", "fov": float(cam.fov_y), "fov_axis": "y",
            "near_clip": 1e-3, "far_clip": 1e4,
            "to_world": look_at(cam.position, cam.target, cam.up),
            "film": {"type": "hdrfilm", "width": int(cam.width), "height": int(cam.height),
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp)},
        },
        "light": {"type": "spot", "intensity": _rgb(light.intensity), "cutoff_angle": float(light.cutoff_angle),
                  "beam_width": float(light.beam_width), "to_world": spot_to_world(light)},
    }
    if has_fog:
        sigma_t = np.asarray(medium.sigma_t, float)
        albedo = np.divide(medium.sigma_s, sigma_t, out=np.zeros(3), where=sigma_t > 0)
        phase = {"type": "hg", "g": float(medium.phase.g)} if medium.phase.kind == "hg" else {"type": "isotropic"}
        d[FOG_ID] = (_homogeneous(sigma_t, albedo, phase) if medium.density is None else
                     _heterogeneous(scene, sigma_t, albedo, phase, volumes))
        d["sensor"]["medium"] = {"type": "ref", "id": FOG_ID}
        d["light"]["medium"] = {"type": "ref", "id": FOG_ID}
        if medium_box:
            lo, hi = medium_bounds(scene)
            d["medium_box"] = {"type": "cube", "bsdf": {"type": "null"}, "interior": {"type": "ref", "id": FOG_ID},
                               "to_world": {"type": "transform",
                                            "ops": [["translate", _vec((lo + hi) / 2)],
                                                    ["scale", _vec((hi - lo) / 2)]]}}
    for i, obj in enumerate(scene.specular):
        shape = {**ply(obj.mesh.load()), "bsdf": {"type": "dielectric", "int_ior": float(obj.ior), "ext_ior": 1.0}}
        if any(obj.absorption):
            shape["interior"] = _homogeneous(obj.absorption, (0.0, 0.0, 0.0))
        if has_fog:
            shape["exterior"] = {"type": "ref", "id": FOG_ID}
        d[f"specular_{i}"] = shape
    for i, surface in enumerate(scene.diffuse):
        d[f"diffuse_{i}"] = {**ply(surface.mesh.load()),
                             "bsdf": {"type": "twosided", "material": {"type": "diffuse",
                                                                        "reflectance": _rgb(surface.albedo)}}}
    return Description(d, meshes, volumes)
