"""An animation's frames: the approximation through one Renderer (meshes uploaded once,
each frame's scene and seed), the reference of every frame through the runner's cache
(``reports.measuring.runner.reference_for``, keyed by each frame's ``scene_hash``), each frame with
its own reference seed (``settings.reference_seed``: independent noise between frames).

Resumable and interrupt-safe: each rendered frame's approximation images (every seed
mode and chain) and times go to ``DIR/.animate/frame-NNNN.npz`` at once (written to a
temporary file, then renamed) with the frame's key (``frame_key``: its scene, the
parameters, seed modes, chains and code version); a later run reads back every frame
whose key matches (another ``--frames`` selection included) instead of rendering it
again, and a finished reference is in the cache.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
import zipfile
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from tqdm import tqdm

from volcaustics.approx import Renderer
from volcaustics.approx.frame_checks import check_finite_frame
from volcaustics.experiment.sizing import sized
from volcaustics.experiment.versions import code_version
from volcaustics.infra.storage import atomic_path
from volcaustics.reports.measuring.results.tables import plain
from volcaustics.reports.measuring.runner import reference_for
from volcaustics.reports.studies.animate.animation_settings import chain_seed, reference_seed
from volcaustics.scenes.formats import COLOUR_LAYERS, MASK_LAYER

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes.model import Scene

WORK = ".animate"  # DIR/.animate: the frames rendered so far
GUIDES = {"distance": 0, "normal": 3}  # the G-buffer stored with each frame: name → channels (0: H×W)


@dataclass
class AnimationFrames:
    """What :func:`render_animation` produced, frame by frame (``frames``: animation frame
    numbers). ``approx``: seed mode → layer → S×T×H×W×C float32 (mask_specular H×W×1);
    ``references``: per frame a ``ReferenceResult``; ``approx_seconds``: per frame the
    median frame time over its renders; ``reference_seconds``: per frame the wall time
    of its reference render (the cache's record when it came from the cache)."""

    scene: Scene
    frames: list
    modes: tuple
    chains: int
    approx: dict
    references: list
    approx_seconds: list
    reference_seconds: list
    reference_cached: list
    resumed: int = 0
    gl: dict = field(default_factory=dict)
    guides: dict = field(default_factory=dict)  # GUIDES name → T×H×W(×3): each frame's G-buffer (approx.temporal)


def frame_key(frame_scene: Scene, params: ApproxParams, modes: Iterable[str], chains: int, frame: int) -> str:
    """SHA-256 of everything that decides one stored frame: its scene, the parameters, seed
    modes and chains (its seeds follow from them and the frame number) and the code."""
    doc = {"scene_hash": frame_scene.scene_hash(), "frame": frame, "params": params.to_dict(), "modes": list(modes),
           "chains": chains, "code_version": code_version()}
    return hashlib.sha256(json.dumps(plain(doc), sort_keys=True).encode()).hexdigest()


def render_animation(scene: Scene, params: ApproxParams, *, frames: list, modes: tuple, chains: int,
                     reference_settings: ReferenceSettings, out_dir: str, progress: bool = True) -> AnimationFrames:
    """Render (or read back) every frame of ``frames`` of ``scene.animation``.

    ``params``: resolved approximation parameters (width/height set); the reference is
    rendered at that size with ``reference_settings``."""
    settings = sized(reference_settings, scene, params)  # the frames' size (params width/height are set)
    work = os.path.join(out_dir, WORK)
    os.makedirs(work, exist_ok=True)
    animation = scene.animation
    renderer = None
    images: dict = {mode: {layer: [] for layer in (*COLOUR_LAYERS, MASK_LAYER)} for mode in modes}
    guides: dict = {name: [] for name in GUIDES}
    gl: dict
    references, approx_seconds, reference_seconds, cached, resumed, gl = [], [], [], [], 0, {}
    try:
        for t in tqdm(frames, desc=f"animate {scene.name}", unit="frame", disable=not progress):
            at = animation.scene_at(scene, t)
            t0 = time.perf_counter()
            reference = reference_for(at, dataclasses.replace(settings, seed=reference_seed(settings.seed, t)),
                                      "continue")
            references.append(reference)
            cached.append(bool(reference.cached))
            reference_seconds.append(float(reference.manifest.get("wall_seconds") or time.perf_counter() - t0))
            key = frame_key(at, params, modes, chains, t)
            stored = _read_frame(work, t, key, modes, (chains, params.height, params.width))
            if stored is None:
                if renderer is None:
                    renderer = Renderer(at)
                    renderer.render(at, params, keep_records=False)  # compiles the shaders: not timed
                stored = _render_frame(renderer, at, params, t, modes, chains)
                _write_frame(work, t, {**stored, "key": np.asarray(key)})
                gl = gl or stored.pop("gl", {})
            else:
                resumed += 1
            for mode in modes:
                for layer in images[mode]:
                    images[mode][layer].append(stored[f"{mode}/{layer}"])
            for name in GUIDES:
                guides[name].append(stored[f"guide/{name}"])
            approx_seconds.append(float(np.median(stored["seconds"])))
    finally:
        if renderer is not None:
            renderer.release()
    approx = {mode: {layer: np.stack(v, axis=1) for layer, v in layers.items()} for mode, layers in images.items()}
    return AnimationFrames(scene=scene, frames=list(frames), modes=tuple(modes), chains=chains,
                           approx=approx, references=references, approx_seconds=approx_seconds,
                           reference_seconds=reference_seconds, reference_cached=cached, resumed=resumed, gl=gl,
                           guides={name: np.stack(v) for name, v in guides.items()})


def _render_frame(renderer, scene, params, t: int, modes, chains: int) -> dict:
    out, seconds = {}, []
    for mode in modes:
        per_layer: dict = {layer: [] for layer in (*COLOUR_LAYERS, MASK_LAYER)}
        for chain in range(chains):
            p = dataclasses.replace(params, seed=chain_seed(mode, params.seed, chain, chains, t))
            frame = renderer.render(scene, p, keep_records=False, keep_guides=True)
            check_finite_frame(frame.images, p, f"{scene.name}: frame {t}")  # NonFiniteFrame: exit 2, none stored
            seconds.append(frame.timings["frame_wall"])
            out["gl"] = frame.gl
            out.update({f"guide/{name}": frame.guides[name].astype(np.float32) for name in GUIDES})
            for layer in per_layer:
                image = frame.images[layer]
                per_layer[layer].append(image[..., :1] if layer == MASK_LAYER else image)
        for layer, stack in per_layer.items():
            out[f"{mode}/{layer}"] = np.stack(stack).astype(np.float32)
    out["seconds"] = np.asarray(seconds, np.float64)
    return out


def _frame_file(work: str, t: int) -> str:
    return os.path.join(work, f"frame-{t:04d}.npz")


def _write_frame(work: str, t: int, arrays: dict) -> None:
    with atomic_path(_frame_file(work, t)) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **{k: v for k, v in arrays.items() if k != "gl"})


def _read_frame(work: str, t: int, key: str, modes, shape: tuple) -> dict | None:
    """The stored frame ``t`` if it is the one ``key`` names and holds the arrays a frame
    of ``shape`` (chains, height, width) has, else None (absent, another run's or
    damaged: rendered again)."""
    path = _frame_file(work, t)
    if not os.path.isfile(path):
        return None
    try:
        with np.load(path) as data:
            arrays = {k: np.asarray(data[k]) for k in data.files}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None
    wanted = {f"{m}/{layer}": (*shape, 1 if layer == MASK_LAYER else 3) for m in modes
              for layer in (*COLOUR_LAYERS, MASK_LAYER)}
    wanted["seconds"] = (len(modes) * shape[0],)
    wanted.update({f"guide/{name}": shape[1:] + ((channels,) if channels else ()) for name, channels in GUIDES.items()})
    for name, dims in wanted.items():  # right key, wrong arrays: a ValueError escaped on stacking
        a = arrays.get(name)
        if a is None or a.shape != dims or a.dtype.kind != "f" or not np.isfinite(a).all():
            return None
    return arrays if str(arrays.get("key", "")) == key else None
