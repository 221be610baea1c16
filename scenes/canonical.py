"""Canonical JSON of a scene and its SHA-256 ``scene_hash``.

Only physical content enters: camera, light, medium, objects (meshes by file
content hash or generator name + parameters, transforms, materials). Labels
(scene name, description, object names, file locations) do not. Keys are
sorted, floats are written with Python's shortest round-trip repr, so the text
and the hash are identical on every machine and every run.
"""

from __future__ import annotations

import hashlib
import json
from typing import TYPE_CHECKING

from .generators import GENERATOR_VERSION

if TYPE_CHECKING:  # types only: model imports this module for Scene.scene_hash
    from .model import MeshSpec, Scene

FORMAT = "volcaustics-scene/1"


def _floats(v):
    return [float(x) for x in v]


def _mesh(spec: MeshSpec) -> dict:
    src = ({"file_sha256": spec.content_hash} if spec.path is not None else
           {"generator": spec.generator, "generator_version": GENERATOR_VERSION,
            "params": {k: v for k, v in spec.params}})
    t = spec.transform
    return {**src, "transform": {"translate": _floats(t.translate), "rotate": _floats(t.rotate),
                                 "scale": float(t.scale)}}


def canonical_dict(scene: Scene) -> dict:
    c, light, m = scene.camera, scene.light, scene.medium
    return {
        "format": FORMAT,
        "camera": {"position": _floats(c.position), "target": _floats(c.target), "up": _floats(c.up),
                   "fov_y": float(c.fov_y), "width": int(c.width), "height": int(c.height)},
        "light": {"position": _floats(light.position), "direction": _floats(light.direction),
                  "intensity": _floats(light.intensity), "cutoff_angle": float(light.cutoff_angle),
                  "beam_width": float(light.beam_width)},
        "medium": {"sigma_s": _floats(m.sigma_s), "sigma_a": _floats(m.sigma_a),
                   "phase": {"kind": m.phase.kind, "g": float(m.phase.g)}},
        "specular": [{"mesh": _mesh(o.mesh), "ior": float(o.ior), "absorption": _floats(o.absorption)}
                     for o in scene.specular],
        "diffuse": [{"mesh": _mesh(o.mesh), "albedo": _floats(o.albedo)} for o in scene.diffuse],
    }


def canonical_json(scene: Scene) -> str:
    return json.dumps(canonical_dict(scene), sort_keys=True, separators=(",", ":"), allow_nan=False)


def scene_hash(scene: Scene) -> str:
    return hashlib.sha256(canonical_json(scene).encode("utf-8")).hexdigest()
