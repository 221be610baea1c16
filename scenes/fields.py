"""Scene fields by dotted path (``medium.sigma_s``, ``light.intensity``,
``specular.0.ior``): a scene with some of its fields changed, validated exactly as the
loader validates a file (``sweep --vary medium.sigma_s=…``), and the scene's optical
depth, the axis such a sweep is read against.

A change is applied to the scene's TOML document (a built-in's file or the SCENE
path), which :func:`scenes.loader.parse_scene` then reads as if the file said so: a
value out of range or a key the format does not have raises the loader's
:class:`SceneError`, naming the key and what is allowed.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from .catalogue import named_path
from .errors import SceneError
from .loader import parse_scene, tomllib  # tomllib, or tomli on Python 3.10

if TYPE_CHECKING:
    from .model import Scene

TABLES = ("camera", "light", "medium", "specular", "diffuse")  # what a path may start with
ARRAYS = ("specular", "diffuse")                               # ... indexed by the object's number


def is_scene_field(name: str) -> bool:
    """Whether a varied or set NAME is a scene field (a dotted path), not a parameter."""
    return "." in name


def parse_field_value(name: str, text: object) -> int | float | str | bool | tuple[float, ...]:
    """A scene field's value from text (CLI: a TOML value, ``0.3`` or ``[0.3, 0.2, 0.1]``
    or a bare word as a string) or as TOML gave it, as a hashable value (a list as a
    tuple): a number, a word, a boolean or a flat list of numbers; SceneError for the
    path or another kind of value (a table, a nested list)."""
    _parts(name, text)
    value = text
    if isinstance(text, str):
        try:
            value = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            value = text.strip()
    if isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return tuple(value)
    if not isinstance(value, (int, float, str, bool)):
        raise SceneError(None, name, value, "a scene field takes a number, a word or a list of numbers "
                                            "(a table or a nested list is not one field)")
    return value


def _parts(name: str, value=None) -> list:
    """The path's parts; SceneError naming ``name`` and the ``value`` given for it."""
    parts = name.split(".")
    if parts[0] not in TABLES or len(parts) < 2 or any(not p for p in parts):
        raise SceneError(None, name, value, f"a scene field is TABLE.KEY with TABLE one of {', '.join(TABLES)} "
                                           f"({', '.join(ARRAYS)} take an index: specular.0.ior)")
    if parts[0] == "camera" and parts[1] in ("width", "height"):
        raise SceneError(None, name, value, f"the image size is the approximation's parameter: use {parts[1]} "
                                           f"(--set {parts[1]}=N), which sizes the reference too")
    if parts[0] in ARRAYS and (len(parts) < 3 or not _index(parts[1])):
        raise SceneError(None, name, value, f"{parts[0]} is a list of objects: give its index, e.g. {parts[0]}.0."
                                           f"{parts[-1]}")
    return parts


def _index(part: str) -> bool:
    """Whether a path part is an object's index: ASCII digits only (``str.isdigit`` also
    takes superscripts and other scripts' digits)."""
    return part.isascii() and part.isdigit()


def _document(arg: str) -> tuple:
    """(TOML document, file label, folder for relative mesh paths) of a SCENE argument."""
    path = named_path(arg) or arg
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh), path, os.path.dirname(os.path.abspath(path))
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError(path, None, None, f"cannot read the scene file ({exc})") from None


def _assign(doc: dict, name: str, value, label: str) -> None:
    parts, node = _parts(name, value), doc
    for i, part in enumerate(parts[:-1]):
        if isinstance(node, list):
            if not _index(part):
                raise SceneError(label, ".".join(parts[: i + 1]), part, "is a list: index it with a number")
            index = int(part)
            if index >= len(node):
                raise SceneError(label, ".".join(parts[: i + 1]), index,
                                 f"the scene has {len(node)} {parts[0]} object(s) (index from 0)")
            node = node[index]
        else:
            node = node.setdefault(part, {} if not (part in ARRAYS and i == 0) else [])
        if not isinstance(node, (dict, list)):
            raise SceneError(label, ".".join(parts[: i + 1]), node, "is a value, not a table")
    if isinstance(node, list):
        raise SceneError(label, name, value, "is an element of a list: set the whole field "
                                             f"({'.'.join(parts[:-1])} = [...])")
    node[parts[-1]] = list(value) if isinstance(value, tuple) else value  # the loader reads TOML arrays


def scene_with(arg: str, fields: dict[str, Any] | Iterable[tuple[str, Any]]) -> Scene:
    """The scene of SCENE argument ``arg`` with ``fields`` ((path, value) pairs or a
    mapping) changed, validated by the loader (SceneError naming the key)."""
    doc, path, base = _document(arg)
    pairs = list(fields.items()) if isinstance(fields, dict) else list(fields)
    changed = ", ".join(f"{name} = {value!r}" for name, value in pairs)
    label = f"{path} (with {changed})" if pairs else path
    for name, value in pairs:
        _assign(doc, name, value, label)
    stem = os.path.splitext(os.path.basename(path))[0]
    if "name" not in doc and stem.isidentifier():
        doc["name"] = stem  # what the loader names the file's scene: not the label's stem
    return parse_scene(doc, file=label, base_dir=base, source=None if named_path(arg) else os.path.abspath(path))


def optical_depth(scene: Scene) -> float:
    """The medium's optical depth along the light's way to what the camera looks at
    and on to the eye: σ̄_t · (|target − light| + |eye − target|), σ̄_t the mean of the
    RGB extinction (docs/decisions.md "Optical depth")."""
    light = np.asarray(scene.light.position, np.float64)
    target, eye = (np.asarray(v, np.float64) for v in (scene.camera.target, scene.camera.position))
    length = float(np.linalg.norm(target - light) + np.linalg.norm(eye - target))
    return float(scene.medium.sigma_bar) * length if math.isfinite(length) else float("nan")


def field_columns(fields: dict | None) -> dict:
    """Changed scene fields as table columns: a number as it is, an RGB list as its mean."""
    return {name: float(np.mean(value)) if isinstance(value, (list, tuple)) else value
            for name, value in (fields or {}).items()}


def field_value(scene: Scene, name: str) -> int | float | str | bool | tuple | None:
    """The value of the scene field ``name`` in ``scene`` (a Scene), as a sweep's column
    shows it: a number or word as it is, an RGB triple as a tuple; None where the model
    has no such attribute."""
    node: Any = scene
    for part in _parts(name):
        if isinstance(node, (list, tuple)) and _index(part):
            node = node[int(part)] if int(part) < len(node) else None
        else:
            node = getattr(node, part, None)
        if node is None:
            return None
    return node if isinstance(node, (int, float, str, bool, tuple)) else None
