"""Scene model shared by both renderers.

Typed immutable dataclasses (camera, spot light, homogeneous medium, specular
and diffuse objects), a validating TOML loader whose every error is a
:class:`SceneError` naming file, key, value and what is allowed, the canonical
JSON and ``scene_hash`` that key caches, procedural and file meshes, the
built-in catalogue of the paper's scenes, and the shared counter-based RNG.
"""

from .catalogue import BUILTIN_NAMES, MEDIA_NAMES, load_builtin, resolve_scene
from .errors import SceneError
from .loader import load_scene, parse_scene
from .model import Camera, DiffuseSurface, Medium, MeshSpec, Phase, Scene, SpecularObject, SpotLight, Transform

__all__ = [
    "BUILTIN_NAMES", "MEDIA_NAMES", "Camera", "DiffuseSurface", "Medium", "MeshSpec", "Phase", "Scene", "SceneError",
    "SpecularObject", "SpotLight", "Transform", "load_builtin", "load_scene", "parse_scene", "resolve_scene",
]
