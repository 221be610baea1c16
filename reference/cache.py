"""On-disk cache of reference renders.

Key: SHA-256 of a JSON document of everything that determines the image
(:func:`key_document`): the scene exactly as Mitsuba gets it
(``reference.description``: medium box, meshes by the hash of their PLY bytes,
normals included, transforms as plain data), the scene model the integrators
read (its canonical form, camera at the image size), the resolved settings, the
light tracer's mode, the integrator code (a hash of its sources) and the Mitsuba
and Dr.Jit versions and variant. Computing it imports no Mitsuba.

An entry is data files ``<key>.<tag>.exr`` (mean and variance layers), ``.png``
(preview) and ``.npz`` (batch state), ``<tag>`` new for every write, and the
manifest ``<key>.json`` written after them, naming them and recording their
SHA-256. Reading checks the hashes and the layers (:func:`load`): a truncated,
swapped or non-finite entry is re-rendered, never served. Continuing an entry
writes new files and switches the manifest over in one rename, so an interrupted
continuation leaves the entry it continued as it was (:func:`store`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import uuid
import zipfile
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.infra.imageio import read_exr, write_exr
from volcaustics.infra.sources import source_hash
from volcaustics.infra.storage import (
    atomic_path,
    atomic_write_bytes,
    atomic_write_text,
    cache_dir,
    cache_path,
    document_sha256,
    file_sha256,
    interrupts_held,
    orphaned,
    owner,
    read_json_object,
    remove_file,
)
from volcaustics.scenes.formats import COLOUR_LAYERS, LAYER_NAMES, MASK_LAYER, MODEL_LAYERS, PATH_INTERACTIONS
from volcaustics.scenes.model import canonical_dict

from . import mi_setup

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

    from .request import RenderRequest
    from .settings import ReferenceSettings

KEY_FORMAT = "volcaustics-reference-key/3"
# The code that turns a description into pixels is the folder reference/render/ (the
# integrators, their shape table, the conversion to Mitsuba objects, the batches and
# their seeds); the exporter's *output* is in the key itself. What finds, reads and
# writes entries (this module) lies outside it and changes no key.
RENDER_FOLDER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "render")
FILE_KINDS = {"exr": ".exr", "png": ".png", "state": ".npz"}  # an entry's data files, named by its manifest
LAYERS = (*LAYER_NAMES, *(f"{name}_var" for name in COLOUR_LAYERS))  # what a reference's EXR holds
MODEL = (*MODEL_LAYERS, *(f"{name}_var" for name in MODEL_LAYERS))  # ... and with max_scatter > 1
SEAL = "manifest_sha256"  # the manifest's field holding the SHA-256 of the rest of it


def code_version() -> str:
    """Hash of the sources under reference/render/ (``infra.sources.source_hash``)."""
    return source_hash({"reference/render": RENDER_FOLDER})


def key_document(request: RenderRequest, variant: str) -> dict:
    """What the key of a resolved :class:`reference.request.RenderRequest` rendered
    with Mitsuba ``variant`` hashes."""
    return {
        "format": KEY_FORMAT,
        "mitsuba_scene": request.description.tree,
        "scene": canonical_dict(request.scene),
        "settings": request.settings.batch_identity(),
        "mode": request.mode,
        "code": code_version(),
        "path_interactions": PATH_INTERACTIONS,  # the light tracer's max_path: a constant outside reference/render
        "mitsuba": {**mi_setup.library_versions(), "variant": variant},
    }


def request_key(request: RenderRequest, variant: str) -> str:
    """Key of a resolved request rendered with ``variant``."""
    text = json.dumps(key_document(request, variant), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def cache_key(scene: Scene, settings: ReferenceSettings | None = None, *, mode: str = "caustic",
              variant: str | None = None) -> str:
    """Key of the reference of ``scene`` with ``settings`` (resolved here, see
    reference.request) and ``mode``, rendered with ``variant`` (default: the one this
    process renders with)."""
    from .request import resolve

    return request_key(resolve(scene, settings, mode), variant or mi_setup.render_variant())


def lookup(request: RenderRequest) -> tuple[str, dict, dict] | None:
    """(key, manifest, layers) of a complete, verified cache entry for ``request``
    rendered with one of the variants this process serves (mi_setup.served_variants,
    in order), else None."""
    size = (request.settings.width, request.settings.height)
    for variant in mi_setup.served_variants():
        key = request_key(request, variant)
        entry = load(key, size)
        if entry is not None:
            return (key, *entry)
    return None


def manifest_path(key: str, *, write: bool = False) -> str:
    """The manifest of a cache entry, ``<key>.json``: it names the entry's data files.
    To ``write``, the folder is made and must be writable (CacheError); to read, a
    read-only cache serves what it holds."""
    return os.path.join(cache_dir("reference") if write else cache_path("reference"), f"{key}.json")


def entry_file(key: str, manifest: dict, kind: str) -> str:
    """Path of the entry's file of ``kind`` (FILE_KINDS) that ``manifest`` names;
    ValueError when it names none, or a name not of the form ``<key>.<tag><ext>`` (a
    manifest names only its own entry's files)."""
    files = manifest.get("files")
    name = files.get(kind) if isinstance(files, dict) else None
    if not isinstance(name, str) or not name.startswith(f"{key}.") or not name.endswith(FILE_KINDS[kind]) \
            or os.path.basename(name) != name:
        raise ValueError(f"cache entry {key}: its manifest names no {kind} file of its own ({name!r})")
    return os.path.join(cache_path("reference"), name)


def load(key: str, size: tuple | None = None) -> tuple[dict, dict] | None:
    """(manifest, layers) of a complete, undamaged entry, else None: the manifest is a
    JSON object of this key naming its files, with fields of the types the cache writes
    (:func:`_manifest_size`), the EXR and PNG match its SHA-256s, and the layers are
    those a reference has, finite, variances ≥ 0, of ``size`` ((width, height); default
    the manifest's settings). A damaged entry is re-rendered, never
    served. An entry of the old layout (a manifest naming no files) counts
    as missing."""
    try:
        manifest = read_json_object(manifest_path(key))  # `null` or a list is a damaged entry, like torn JSON
        if manifest.get("key") != key or manifest.get(SEAL) != document_sha256(manifest, SEAL):
            return None  # another entry's, or a number edited (a noise floor, the batches): damaged
        for kind in ("exr", "png"):
            if manifest.get(f"{kind}_sha256") != file_sha256(entry_file(key, manifest, kind)):
                return None
        size = _manifest_size(manifest, size)
        if size is None:
            return None
        model = manifest["settings"].get("max_scatter", 1) > 1
        layers = _verified(read_exr(entry_file(key, manifest, "exr"))[0], size, model)
    except (OSError, ValueError, KeyError, TypeError, RuntimeError):  # OpenEXR raises RuntimeError
        return None
    return None if layers is None else (manifest, layers)


def _manifest_size(manifest: dict, size: tuple | None) -> tuple | None:
    """The image size (width, height) of a manifest whose fields that callers read have
    the types the cache writes (settings a table of this size, when ``size`` is given;
    counts whole numbers ≥ 0; noise floors finite or None; seconds finite ≥ 0), else None."""
    settings = manifest.get("settings")
    if not isinstance(settings, dict):
        return None
    own = (settings.get("width"), settings.get("height"))
    counts = [manifest.get(name) for name in ("photons", "batches", "camera_batches")]
    floors = manifest.get("noise_floor")
    if (size is not None and own != tuple(size)) or not all(_count(v) for v in (*own, *counts)) \
            or not isinstance(floors, dict) or not all(v is None or _number(v) for v in floors.values()) \
            or not _number(manifest.get("wall_seconds")):
        return None
    return own


def _count(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _number(value) -> bool:
    """A finite number ≥ 0 (JSON gives NaN and Infinity as floats)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value >= 0


def _verified(layers: dict, size: tuple, model: bool = False) -> dict | None:
    """``layers`` if they are exactly a reference's (LAYERS, and MODEL when ``model``:
    rendered with more than one scattering order), each H×W×3 of ``size`` (width, height), finite, variances ≥ 0
    and the mask 0 or 1; else None."""
    width, height = size
    if set(layers) != ({*LAYERS, *MODEL} if model else set(LAYERS)):
        return None
    for name, image in layers.items():
        if image.shape != (height, width, 3) or not np.isfinite(image).all():
            return None
        if name.endswith("_var") and (image < 0).any():
            return None
    mask = layers[MASK_LAYER]
    return layers if ((mask == 0) | (mask == 1)).all() else None


def store(key: str, layers: dict, manifest: dict, header: dict, png: bytes, state: dict | None = None) -> dict:
    """Write the EXR, the PNG preview and the batch state (``state``: arrays of float64
    batch sums, to continue the render) into new files ``<key>.<tag>.{exr,png,npz}``,
    then the manifest naming them (the switch: one rename, Ctrl-C held back), then
    remove the files the previous manifest named. An entry being continued stays
    valid until the switch; an interrupted write removes its new files."""
    folder = cache_dir("reference")
    _remove_orphans(folder)
    tag = f"{owner()}-{uuid.uuid4().hex[:12]}"  # whose: a killed writer's files are found by the next
    kinds = ("exr", "png", "state") if state is not None else ("exr", "png")
    names = {kind: f"{key}.{tag}{FILE_KINDS[kind]}" for kind in kinds}
    paths = {kind: os.path.join(folder, name) for kind, name in names.items()}
    previous = _named_files(key)
    committed = False
    try:
        write_exr(paths["exr"], layers, {**header, "volcaustics_reference_key": key})
        atomic_write_bytes(paths["png"], png)
        if state is not None:
            with atomic_path(paths["state"]) as tmp:
                np.savez(tmp, **state)
        manifest = json.loads(json.dumps({**manifest, "key": key, "files": names,
                                          **{f"{kind}_sha256": file_sha256(path) for kind, path in paths.items()}},
                                         default=float))
        manifest[SEAL] = document_sha256(manifest, SEAL)
        with interrupts_held():
            atomic_write_text(manifest_path(key, write=True), json.dumps(manifest, indent=2, default=float))
            committed = True
    finally:
        if not committed:
            for path in paths.values():
                remove_file(path)
    for path in previous - set(paths.values()):
        remove_file(path)
    return manifest


# A data file: <key>.<host>-<pid>-<12 hex>.<ext> (store's tag)
_DATA_FILE = re.compile(r"^(?P<key>[0-9a-f]{32})\.(?P<host>[^./]+)-(?P<pid>\d+)-[0-9a-f]{12}\.(exr|png|npz)$")


def _remove_orphans(folder: str) -> None:
    """Remove data files that a killed writer (SIGKILL between its files and its
    manifest: no ``finally`` ran) left and no manifest names."""
    for name in os.listdir(folder):
        match = _DATA_FILE.match(name)
        if match and orphaned(match["host"], int(match["pid"])):
            path = os.path.join(folder, name)
            if path not in _named_files(match["key"]):
                remove_file(path)


def _named_files(key: str) -> set:
    """The data files the entry's current manifest names (none when it is missing or
    damaged)."""
    try:
        manifest = read_json_object(manifest_path(key))
    except (OSError, ValueError):
        return set()
    out = set()
    for kind in FILE_KINDS:
        try:
            out.add(entry_file(key, manifest, kind))
        except ValueError:
            pass
    return out


def read_state(key: str, manifest: dict, prefix: str | tuple = "", verified: bool = False) -> dict | None:
    """The entry's batch state (float64 sums per stream, reference.batches; the arrays
    whose names start with ``prefix``, a string or a tuple) if it matches its manifest
    (``verified``: its hash was checked already; the file of a continued entry is gone)."""
    try:
        path = entry_file(key, manifest, "state")
        if not verified and manifest.get("state_sha256") != file_sha256(path):
            return None
        with np.load(path) as data:
            return {name: data[name] for name in data.files if name.startswith(prefix)}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None


class ReferenceResult:
    """A cached reference: ``manifest`` (photons, batches, seed, wall time, variant,
    versions, the caller's scene name and hash, settings, cached), ``exr_path``/``png_path`` of the cache
    files (removed when the entry is continued later: copy them at once), and the
    verified images: ``mean`` (layer → H×W×3 float32; mask_specular 0/1) and ``var``
    (layer → variance of the mean)."""

    def __init__(self, key: str, manifest: dict, cached: bool, layers: dict):
        self.key, self.manifest, self.cached = key, {**manifest, "cached": cached}, cached
        self.exr_path = entry_file(key, manifest, "exr")
        self.png_path = entry_file(key, manifest, "png")
        self._layers, self._state_verified = layers, False  # the state's hash checked once, by groups()

    @property
    def mean(self) -> dict:
        return {k: v for k, v in self._layers.items() if not k.endswith("_var")}

    @property
    def var(self) -> dict:
        return {k[:-4]: v for k, v in self._layers.items() if k.endswith("_var")}

    def total_variance_ratio(self, layer: str) -> list | None:
        """Per channel, the variance of ``layer``'s total over Σ of its pixels' (the
        manifest's, ``reference.render.batches.total_variance_ratio``; None where the
        entry does not say: take its pixels as independent)."""
        return (self.manifest.get("total_variance_ratio") or {}).get(layer)

    def groups(self, layer: str) -> tuple | None:
        """(G×H×W×3 means of ``layer``'s batch groups, their G counts): the caustic or a
        model term ``<component>_ms``, from the batch state; None where it has none."""
        from .render.batches import LIGHT, LIGHT_GROUPS, ORDERS, BatchStats

        stream = LIGHT if layer == "caustic" else ORDERS
        arrays = read_state(self.key, self.manifest, (f"{stream}/n", f"{stream}/groups", f"{stream}/group/{layer}"),
                            verified=self._state_verified)
        if arrays is None or f"{stream}/n" not in arrays:
            return None
        self._state_verified = True
        try:
            return BatchStats.stored_group_means(arrays, stream, layer, LIGHT_GROUPS)
        except (KeyError, ValueError, TypeError):
            return None


def for_caller(manifest: dict, scene: Scene) -> dict:
    """A cached manifest with the caller's scene name and hash: one entry serves every
    scene that renders the same (other labels, another camera size with settings naming
    the size), and the caller is told about the scene it passed."""
    return {**manifest, "scene": scene.name, "scene_hash": scene.scene_hash()}


def cached_reference(key: str, scene: Scene, content: str | None = None) -> ReferenceResult | None:
    """The complete, verified cache entry ``key`` as a result for ``scene``, or None if
    this cache does not hold it, or (``content``: its EXR's SHA-256) holds another render
    under the key, an entry continued since: a worker measures exactly the reference its
    run resolved."""
    entry = load(key)
    if entry is None or (content is not None and entry[0].get("exr_sha256") != content):
        return None
    return ReferenceResult(key, for_caller(entry[0], scene), cached=True, layers=entry[1])


def existing_reference(scene: Scene, settings: ReferenceSettings | None = None, *,
                       mode: str = "caustic") -> ReferenceResult | None:
    """The cache entry for ``scene`` and ``settings`` as it is (whatever its batches or
    floors, never continued), or None when there is none."""
    from .request import resolve

    served = lookup(resolve(scene, settings, mode))
    if served is None:
        return None
    key, manifest, layers = served
    return ReferenceResult(key, for_caller(manifest, scene), cached=True, layers=layers)
