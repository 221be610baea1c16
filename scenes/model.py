"""Typed, immutable scene description shared by both renderers.

Conventions (docs/conventions.md): right-handed world, +y up, metres; angles in degrees in
the scene description; RGB triples are linear Rec.709 primaries. Instances are
frozen dataclasses; derive variants with :func:`dataclasses.replace`.

A scene's identity is here too: :func:`canonical_json` and its SHA-256
:func:`scene_hash`. Only physical content enters: camera, light, medium, objects (meshes
by file content hash or generator name + parameters, transforms, materials). Labels
(scene name, description, object names, file locations) do not. Keys are sorted, floats
are written with Python's shortest round-trip repr, so the text and the hash are
identical on every machine and every run.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .density import Density
from .generators import GENERATOR_VERSION
from .mesh_cache import load_mesh_spec

if TYPE_CHECKING:
    from .mesh import Mesh

FORMAT = "volcaustics-scene/1"  # the canonical JSON's format: a change re-keys every cache

Vec3 = tuple[float, float, float]
RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Camera:
    """Pinhole camera with a box pixel filter.

    ``fov_y`` is the *vertical* field of view in degrees; the image is
    ``width`` × ``height`` pixels, row 0 at the top.
    """

    position: Vec3
    target: Vec3
    up: Vec3 = (0.0, 1.0, 0.0)
    fov_y: float = 40.0
    width: int = 512
    height: int = 512

    @property
    def forward(self) -> np.ndarray:
        """Unit view direction (3,) float64."""
        d = np.subtract(self.target, self.position, dtype=np.float64)
        return d / np.linalg.norm(d)


@dataclass(frozen=True)
class SpotLight:
    """Spot light with exactly the parameters of Mitsuba's ``spot`` emitter.

    ``intensity`` is the radiant intensity on the axis in W/sr (RGB);
    ``cutoff_angle`` and ``beam_width`` are half-angles in degrees, with
    0 < beam_width <= cutoff_angle < 90. ``direction`` is a unit vector.
    """

    position: Vec3
    direction: Vec3
    intensity: RGB
    cutoff_angle: float = 20.0
    beam_width: float = 15.0


@dataclass(frozen=True)
class Phase:
    """Phase function: ``kind`` is ``"isotropic"`` or ``"hg"`` (Henyey–Greenstein, mean cosine ``g``)."""

    kind: str = "isotropic"
    g: float = 0.0


@dataclass(frozen=True)
class Medium:
    """The medium filling the scene outside the objects.

    ``sigma_s`` and ``sigma_a`` are scattering and absorption coefficients in 1/m
    (RGB, >= 0). All zero means vacuum. ``density`` (``scenes.density``) makes it
    heterogeneous: σs(x) = ρ(x)·sigma_s and σa(x) = ρ(x)·sigma_a; None is ρ ≡ 1.
    """

    sigma_s: RGB = (0.0, 0.0, 0.0)
    sigma_a: RGB = (0.0, 0.0, 0.0)
    phase: Phase = field(default_factory=Phase)
    density: Density | None = None

    @property
    def is_heterogeneous(self) -> bool:
        return self.density is not None and not self.is_vacuum

    @property
    def sigma_t(self) -> RGB:
        """Extinction coefficient sigma_s + sigma_a (1/m, RGB)."""
        (s0, s1, s2), (a0, a1, a2) = self.sigma_s, self.sigma_a
        return (s0 + a0, s1 + a1, s2 + a2)

    @property
    def sigma_bar(self) -> float:
        """Free-flight sampling rate (1/m): the mean of sigma_t over RGB, 0 for vacuum.

        Both photon tracers draw medium collisions at this one rate, d = −ln(1−ξ)/sigma_bar,
        and weight what they carry so that RGB sigma_t stays unbiased (see approx/trace.py);
        for a grey medium sigma_bar = sigma_t. The GPU receives it as a float32 uniform:
        tracers that replay the GPU's draws round it with ``np.float32``.
        """
        return float(np.mean(self.sigma_t))

    @property
    def is_vacuum(self) -> bool:
        return not any(self.sigma_t)


@dataclass(frozen=True)
class Transform:
    """Placement of a mesh: scale (uniform), then rotate (Euler degrees about x, then y, then z), then translate."""

    translate: Vec3 = (0.0, 0.0, 0.0)
    rotate: Vec3 = (0.0, 0.0, 0.0)
    scale: float = 1.0

    def matrix(self) -> np.ndarray:
        """4×4 float64 object-to-world matrix."""
        rx, ry, rz = (math.radians(a) for a in self.rotate)
        cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
        mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        m = np.eye(4)
        m[:3, :3] = mz @ my @ mx * self.scale
        m[:3, 3] = self.translate
        return m


@dataclass(frozen=True)
class MeshSpec:
    """Where a mesh comes from: a file (``path``, absolute, PLY or OBJ) or a
    procedural ``generator`` with ``params`` (sorted key/value pairs), then ``transform``.

    ``content_hash`` is the SHA-256 of the file bytes (file meshes) so that the
    scene hash follows the geometry, not where the file lies.
    """

    path: str | None = None
    generator: str | None = None
    params: tuple[tuple[str, Any], ...] = ()
    transform: Transform = field(default_factory=Transform)
    content_hash: str | None = None

    def load(self) -> Mesh:
        """The world-space :class:`scenes.mesh.Mesh` (cached per spec)."""
        return load_mesh_spec(self)

    @property
    def label(self) -> str:
        return self.path if self.path is not None else f"generator {self.generator}"


@dataclass(frozen=True)
class SpecularObject:
    """Closed dielectric mesh: index of refraction ``ior`` (>= 1) and interior
    Beer–Lambert ``absorption`` coefficient (1/m, RGB, >= 0)."""

    name: str
    mesh: MeshSpec
    ior: float = 1.5
    absorption: RGB = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class DiffuseSurface:
    """Lambertian surface (need not be closed) with RGB ``albedo`` in [0, 1]."""

    name: str
    mesh: MeshSpec
    albedo: RGB = (0.5, 0.5, 0.5)


@dataclass(frozen=True)
class Scene:
    """A whole scene. ``name``, ``description`` and ``source`` are labels and do
    not enter :meth:`scene_hash`; every physical parameter does. ``animation`` (an
    optional sequence of frames, each a static scene: ``Animation.scene_at``) does not
    enter it either: it is this scene at rest that renders."""

    name: str
    camera: Camera
    light: SpotLight
    medium: Medium = field(default_factory=Medium)
    specular: tuple[SpecularObject, ...] = ()
    diffuse: tuple[DiffuseSurface, ...] = ()
    description: str = ""
    source: str | None = None
    animation: Any = None  # scenes.animation.Animation or None: frames of this scene (not in scene_hash)

    def canonical_json(self) -> str:
        return canonical_json(self)

    def scene_hash(self) -> str:
        """SHA-256 (hex) of :meth:`canonical_json`: stable across runs and machines."""
        return scene_hash(self)

    def specular_triangle_count(self) -> int:
        return sum(len(obj.mesh.load().faces) for obj in self.specular)


def _floats(v):
    return [float(x) for x in v]


def _mesh(spec: MeshSpec) -> dict:
    src = ({"file_sha256": spec.content_hash} if spec.path is not None else
           {"generator": spec.generator, "generator_version": GENERATOR_VERSION,
            "params": {k: v for k, v in spec.params}})
    t = spec.transform
    return {**src, "transform": {"translate": _floats(t.translate), "rotate": _floats(t.rotate),
                                 "scale": float(t.scale)}}


def _medium(m: Medium) -> dict:
    out = {"sigma_s": _floats(m.sigma_s), "sigma_a": _floats(m.sigma_a),
           "phase": {"kind": m.phase.kind, "g": float(m.phase.g)}}
    if m.density is not None:  # a homogeneous medium's text (and hash) is what it always was
        out["density"] = m.density.canonical()
    return out


def canonical_dict(scene: Scene) -> dict:
    c, light = scene.camera, scene.light
    return {
        "format": FORMAT,
        "camera": {"position": _floats(c.position), "target": _floats(c.target), "up": _floats(c.up),
                   "fov_y": float(c.fov_y), "width": int(c.width), "height": int(c.height)},
        "light": {"position": _floats(light.position), "direction": _floats(light.direction),
                  "intensity": _floats(light.intensity), "cutoff_angle": float(light.cutoff_angle),
                  "beam_width": float(light.beam_width)},
        "medium": _medium(scene.medium),
        "specular": [{"mesh": _mesh(o.mesh), "ior": float(o.ior), "absorption": _floats(o.absorption)}
                     for o in scene.specular],
        "diffuse": [{"mesh": _mesh(o.mesh), "albedo": _floats(o.albedo)} for o in scene.diffuse],
    }


def canonical_json(scene: Scene) -> str:
    return json.dumps(canonical_dict(scene), sort_keys=True, separators=(",", ":"), allow_nan=False)


def scene_hash(scene: Scene) -> str:
    return hashlib.sha256(canonical_json(scene).encode("utf-8")).hexdigest()
