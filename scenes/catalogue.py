"""The built-in scene catalogue and SCENE-argument resolution.

Built-in scenes are ordinary TOML files in ``scenes/builtin/`` (they double as
examples of the format): the catalogue is that folder, each file's stem a scene's name,
in the order its top-level ``order`` key gives (the paper's: Table 1's ``sphere1``,
``sphere2``, ``bunny``, ``feline`` (stand-in), ``skull`` (stand-in), then Figure 5's
``two_spheres``, ``refocus``). A file dropped there is a built-in scene
(``docs/howto/add-scene.md``).

Media scenes (``scenes/media/``: ``fogbank``, a glass sphere's focus in ground fog, and
``smoke``, a sphere focusing into a plume; docs/concepts/heterogeneous-media.md) are named
like the built-ins (``volcaustics measure fogbank``) but measured apart: a point of theirs
costs the exact images' splats through the exact-transmittance programs, so they have a
report and budgets of their own (``make report-media``) instead of growing the report's.

Held-out scenes (``scenes/heldout/``: ``knot``, ``lens_array``, ``dense_forward``,
``water``, ``coil``, ``layered_fog``: a slab of two densities) are
scene files of other character that no search may tune on: the cross-validation of a
configuration chosen on the built-ins (docs/decisions.md "Held-out scenes"). They are
named by path (:func:`heldout_path`), never by a built-in name.
"""

from __future__ import annotations

import os

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from .errors import SceneError
from .loader import load_scene
from .model import Scene


def catalogue(folder: str) -> tuple[str, ...]:
    """The scenes of ``folder``: its ``.toml`` files' stems, by their ``order`` key (files
    without one after those with one, by name). Two files of one ``order`` are a
    SceneError naming both."""
    ranked: dict[str, tuple[float, str]] = {}
    taken: dict[int, str] = {}
    for entry in sorted(os.listdir(folder)):
        stem, ext = os.path.splitext(entry)
        if ext != ".toml":
            continue
        path = os.path.join(folder, entry)
        with open(path, "rb") as fh:
            order = tomllib.load(fh).get("order")
        if isinstance(order, int) and order in taken:
            raise SceneError(path, "order", order, f"the place of {taken[order]} already: give each scene its own")
        if isinstance(order, int):
            taken[order] = entry
        ranked[stem] = (order if isinstance(order, int) else float("inf"), stem)
    return tuple(sorted(ranked, key=ranked.__getitem__))


BUILTIN_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "builtin")
BUILTIN_NAMES = catalogue(BUILTIN_DIR)


MEDIA_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "media")
MEDIA_NAMES = catalogue(MEDIA_DIR)


HELDOUT_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "heldout")
HELDOUT_NAMES = catalogue(HELDOUT_DIR)


def heldout_path(name: str) -> str:
    """The scene file of held-out scene ``name`` (one of HELDOUT_NAMES)."""
    if name not in HELDOUT_NAMES:
        raise SceneError(None, "SCENE", name, f"expected a held-out scene ({', '.join(HELDOUT_NAMES)})")
    return os.path.join(HELDOUT_DIR, f"{name}.toml")


def builtin_path(name: str) -> str:
    return os.path.join(BUILTIN_DIR, f"{name}.toml")


def named_path(name: str) -> str | None:
    """The file of the scene a SCENE argument names (a built-in or a media scene), None
    when ``name`` names none."""
    if name in BUILTIN_NAMES:
        return builtin_path(name)
    if name in MEDIA_NAMES:
        return os.path.join(MEDIA_DIR, f"{name}.toml")
    return None


def _names() -> str:
    return f"a built-in scene ({', '.join(BUILTIN_NAMES)}), a media scene ({', '.join(MEDIA_NAMES)})"


def load_builtin(name: str) -> Scene:
    if name not in BUILTIN_NAMES:
        raise SceneError(None, "SCENE", name, f"expected a built-in scene ({', '.join(BUILTIN_NAMES)})")
    return load_scene(builtin_path(name))


def is_scene_path(arg: str) -> bool:
    """Whether a SCENE argument names a scene file (else a built-in or media scene's name)."""
    return named_path(arg) is None and (arg.endswith(".toml") or os.sep in arg)


def scene_relative_to(arg: str, named_in: str) -> str:
    """A SCENE named in the file ``named_in`` (a sweep spec, a budgets file): a scene
    file's relative path is relative to that file's folder, as a scene file's mesh
    paths are to it; scene names and absolute paths stay as they are."""
    if not is_scene_path(arg):
        return arg
    base = os.path.dirname(os.path.abspath(named_in))
    return os.path.normpath(os.path.join(base, os.path.expanduser(arg)))


def resolve_scene(arg: str | os.PathLike) -> Scene:
    """A SCENE argument: a built-in or media scene's name or a path to a TOML scene file (a
    string, or a path object); SceneError for anything else."""
    if isinstance(arg, os.PathLike):
        arg = os.fspath(arg)
    if not isinstance(arg, str):
        raise SceneError(None, "SCENE", arg, f"expected {_names()} or a scene file's path, not a "
                                             f"{type(arg).__name__}")
    named = named_path(arg)
    if named is not None:
        return load_scene(named)
    if is_scene_path(arg) or os.path.exists(arg):
        return load_scene(arg)
    raise SceneError(None, "SCENE", arg, f"expected {_names()} or a path to a .toml file")
