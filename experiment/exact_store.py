"""The decomposition's exact images, stored under their own key and reused.

The E images (E_k, E_∞ with A's Fresnel, E_∞ stochastic, E_em, E_∞,s, E_∞,s,τ) replay A's
emission and the light's true emission exactly from the emission ray: they depend on
the scene, the emission, the Fresnel mode, ``steps``, the seeds, the sub-photons, the
photon grid and the splat, not on how A searched. The parameters the table marks
``exact=False`` (``approx.params``: the layers, the search, the crossing and start
rules, the light maps' size, the fog) are therefore left out of their key, so a sweep
over them computes the E images once per scene and seed set and reads them back for
every other point. With adaptive or density splats the E images take the kernels of A's
real frames (``experiment.kernels``), so every parameter is in the key.

An entry is ``$VOLCAUSTICS_CACHE/exact-images/<key>.npz`` (the batch images,
compressed) and ``<key>.json`` (written last: the key's document, the alive fractions,
the small kernel and the npz file's SHA-256). An entry that does not verify is computed
again; a cache that cannot be written is noted once and the images are computed each
time.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.approx.params import PARAMS
from volcaustics.experiment.versions import code_version
from volcaustics.infra.storage import (
    CacheError,
    atomic_write_bytes,
    atomic_write_text,
    cache_dir,
    cache_path,
    note_not_cached,
    read_json_object,
)

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.scenes.model import Scene

FOLDER = "exact-images"
FORMAT = 4  # 2: every E image from the emission ray, and E_em; 3: the real frame's kernels, E_∞,s fixed; 4: E_∞,s,τ
EXACT_IMAGES = ("exact_steps", "exact_all_same", "exact_all", "exact_emission", "exact_all_small",
                "exact_all_small_eye")
# images equal to another in a homogeneous medium (no camera volume): stored only where they differ
ALIASES = {"exact_all_small_eye": "exact_all_small"}
SEARCH_ONLY = tuple(p.name for p in PARAMS if not p.exact)  # what the E images do not depend on


def exact_document(scene: Scene, p: ApproxParams, seeds: list, subphotons: int, constants: dict,
                   controls: dict) -> dict:
    """What determines the E images of a point: the scene, the resolved parameters
    without SEARCH_ONLY (all of them for splat = adaptive), the seeds, the sub-photons,
    the replay's constants and the code version."""
    params = p.to_dict()
    if p.splat == "fixed":
        params = {k: v for k, v in params.items() if k not in SEARCH_ONLY and k != "seed"}
    return {"format": FORMAT, "scene_hash": scene.scene_hash(), "params": params, "seeds": [int(s) for s in seeds],
            "subphotons": int(subphotons), "constants": constants, "code_version": code_version(),
            "test_defines": {k: str(v) for k, v in sorted(controls.items())}}  # the renderer's controls


def with_aliases(batches: dict) -> dict:
    """``batches`` with every alias it lacks (ALIASES) set to its image."""
    return {**batches, **{name: batches[alias] for name, alias in ALIASES.items() if name not in batches}}


def exact_key(document: dict) -> str:
    text = json.dumps(document, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def load_exact(key: str, document: dict) -> dict | None:
    """The stored E images of ``key`` ({"batches": name → K×H×W×3 float32, "alive",
    "small_radius"}), or None when absent or not verified (other document, damaged
    or edited file, wrong shapes, non-finite values)."""
    manifest_path = cache_path(FOLDER, key + ".json")
    if not os.path.isfile(manifest_path):
        return None
    try:
        manifest = read_json_object(manifest_path)
        with open(cache_path(FOLDER, key + ".npz"), "rb") as fh:
            data = fh.read()
        if manifest.get("document") != document or hashlib.sha256(data).hexdigest() != manifest.get("npz_sha256"):
            return None
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            batches = {name: npz[name] for name in EXACT_IMAGES if name in npz or name not in ALIASES}
    except (OSError, ValueError, KeyError):
        return None
    batches = with_aliases(batches)
    shapes = {b.shape for b in batches.values()}
    if len(shapes) != 1 or any(b.dtype != np.float32 or not np.isfinite(b).all() for b in batches.values()):
        return None
    return {"batches": batches, "alive": manifest["alive"], "small_radius": manifest["small_radius"]}


def save_exact(key: str, document: dict, exact: dict) -> None:
    """Store ``exact`` (as :func:`load_exact` returns it) under ``key``: the images
    first (an alias not when it is its image), the manifest last; a cache that cannot
    be written is noted, not an error."""
    batches = exact["batches"]
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **{name: batches[name] for name in EXACT_IMAGES
                                   if name in batches and batches[name] is not batches.get(ALIASES.get(name))})
    data = buffer.getvalue()
    manifest = {"document": document, "alive": exact["alive"], "small_radius": float(exact["small_radius"]),
                "npz_sha256": hashlib.sha256(data).hexdigest()}
    try:
        folder = cache_dir(FOLDER)
        atomic_write_bytes(os.path.join(folder, key + ".npz"), data)
        atomic_write_text(os.path.join(folder, key + ".json"), json.dumps(manifest, sort_keys=True))
    except (CacheError, OSError) as exc:
        note_not_cached(exc, "the decomposition's exact images")
