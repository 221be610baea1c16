"""Another renderer's images of a scene, read and checked before anything renders.

Each file is one frame (one seed) in OpenEXR: the layers ``caustic``, ``fog`` and
``direct`` (channels ``caustic.R``, ``caustic.G``, ``caustic.B``, …; ``combined`` is
their sum unless the file holds it), or only root ``R``, ``G``, ``B`` channels, taken
as ``combined``. An optional ``mask_specular`` layer (``.Y`` or ``.R``: 1 where the
camera sees glass) joins the reference's in excluding pixels. Every file must have
the same size, with the scene camera's aspect ratio, and the same layers; pixels must
be finite and ≥ 0 (linear radiance, box pixel filter: docs/conventions.md).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

import numpy as np

from volcaustics.experiment.point_checks import check_images_fit
from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import file_sha256, special_file_kind
from volcaustics.scenes.formats import COLOUR_LAYERS, MASK_LAYER

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

EXR_MAGIC = b"\x76\x2f\x31\x01"   # OpenEXR's first four bytes
PNG_MAGIC = b"\x89PNG"
SUMMED = tuple(c for c in COLOUR_LAYERS if c != "combined")   # the layers whose sum is `combined`
ROOT = "combined"                  # what root R, G, B channels are taken as
COMBINED_TOLERANCE = 1e-3          # |combined − Σ layers| / Σ layers beyond which summary.json warns
# What compare holds per pixel (the files' layers, the reference's film and layers, every
# metric): 1.23 kB + 0.23 kB per file measured as peak RSS per pixel, rounded up
# (bench/image_memory.py compare, docs/decisions.md "Image sizes against memory").
BYTES_PER_PIXEL = (1300, 250)
CONVENTION = ("OpenEXR, linear radiance (W·m⁻²·sr⁻¹, Rec.709), box pixel filter, layers caustic/fog/direct "
              "(channels caustic.R, …) or root R, G, B as combined")


class CompareError(InputError):
    """An image ``compare`` cannot judge (not an EXR, wrong size, missing layers,
    NaN/∞ or negative pixels) or a comparison folder that cannot be read: exit 2; the
    message names the file and the problem."""


@dataclass
class Frame:
    """One file as a frame: layer name → H×W×3 float32 (every compared component and
    ``mask_specular``, zero where the file has none)."""

    images: dict


@dataclass
class Inputs:
    frames: list
    width: int
    height: int
    components: tuple               # the colour components compared
    mask: str                       # "file" (the files' mask_specular and the reference's) or "reference"
    files: list                     # per file: {"path", "sha256", "layers"}
    warnings: list = field(default_factory=list)


def read_images(paths: Sequence[str], scene: Scene) -> Inputs:
    """The files ``paths`` (one per seed) as frames of ``scene``, checked (CompareError)."""
    if not paths:
        raise CompareError("no image given: compare SCENE IMAGE.exr [IMAGE2.exr …]")
    sizes = [_header_size(path) for path in paths]  # before any pixel is read
    _distinct_files(paths)
    first_path, (width, height) = paths[0], sizes[0]
    for path, (w, h) in zip(paths, sizes):
        if (w, h) != (width, height):
            raise CompareError(f"{path}: {w}×{h} pixels, but {first_path} has {width}×{height}: every seed's image "
                               f"must have the same size")
    _check_size(first_path, width, height, scene)
    check_images_fit(width, height, len(paths), BYTES_PER_PIXEL, f"compare's images with {len(paths)} file(s) "
                     f"(the files' layers, the reference at their size, every metric)")
    read = [_channels(path, scene) for path in paths]
    hashes = [file_sha256(path) for path in paths]
    for j, digest in enumerate(hashes):
        if digest in hashes[:j]:
            raise CompareError(f"{paths[j]}: the same bytes as {paths[hashes.index(digest)]}: each file must be a "
                               f"render of its own seed (two copies of one frame make the renderer's noise 0)")
    layers = _layers(first_path, read[0])
    warnings: list
    frames, files, warnings = [], [], []
    for path, channels, sha256 in zip(paths, read, hashes):
        h, w = next(iter(channels.values())).shape
        if (w, h) != (width, height):
            raise CompareError(f"{path}: its pixels are {w}×{h}, but its header says {width}×{height}")
        if _layers(path, channels) != layers:
            raise CompareError(f"{path}: layers {', '.join(_layers(path, channels))}, but {first_path} has "
                               f"{', '.join(layers)}: every seed's image must hold the same layers")
        images = _frame_images(path, channels, layers, warnings)
        frames.append(Frame(images))
        files.append({"path": os.path.abspath(path), "sha256": sha256, "layers": list(layers)})
    components = COLOUR_LAYERS if SUMMED[0] in layers else (ROOT,)
    return Inputs(frames=frames, width=width, height=height, components=components,
                  mask="file" if MASK_LAYER in layers else "reference", files=files, warnings=warnings)


def _distinct_files(paths) -> None:
    """CompareError naming both arguments when two name one file: the same path, two
    spellings of it, a symbolic or a hard link (``os.path.samefile``)."""
    for j in range(len(paths)):
        for i in range(j):
            if os.path.samefile(paths[i], paths[j]):
                same = "given twice" if paths[i] == paths[j] else f"the same file as {paths[i]}"
                raise CompareError(f"{paths[j]}: {same}: each file is one seed, name each once")


def _opened(path: str) -> None:
    """CompareError unless ``path`` is a readable OpenEXR file (by its first bytes)."""
    special = special_file_kind(path)
    if special:  # never opened: a FIFO would block
        raise CompareError(f"{path}: is {special}, not an image file")
    try:
        with open(path, "rb") as fh:
            magic = fh.read(4)
    except FileNotFoundError:
        raise CompareError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise CompareError(f"{path}: is a folder, not an image file") from None
    except OSError as exc:
        raise CompareError(f"{path}: unreadable ({exc.strerror or exc})") from None
    if magic == PNG_MAGIC:
        raise CompareError(f"{path}: is a PNG (8-bit, tonemapped): compare needs {CONVENTION}")
    if magic != EXR_MAGIC:
        raise CompareError(f"{path}: not an OpenEXR file (its first bytes are {magic!r}): compare needs {CONVENTION}")


def _header_size(path: str) -> tuple:
    """(width, height) of the OpenEXR file ``path`` from its header alone (its data
    window), so that a size that cannot be measured is refused before the pixels load."""
    _opened(path)
    import OpenEXR

    try:
        with OpenEXR.File(path, header_only=True) as f:
            lo, hi = f.header()["dataWindow"]
    except Exception as exc:  # OpenEXR raises its own types for a damaged file
        raise CompareError(f"{path}: unreadable OpenEXR ({exc})") from None
    return int(hi[0]) - int(lo[0]) + 1, int(hi[1]) - int(lo[1]) + 1


def _channels(path: str, scene) -> dict:
    """Channel name → H×W float32 of every part of the OpenEXR file ``path``; a file
    whose header names the scene it was rendered from (``volcaustics_scene_hash``, as
    this project's renderers write) must name ``scene``. ``path`` passed
    :func:`_header_size` (a readable OpenEXR file)."""
    import OpenEXR

    try:
        with OpenEXR.File(path, separate_channels=True) as f:
            header, channels = dict(f.header()), {}
            for part in f.parts:
                for name, channel in part.channels.items():
                    channels[name] = np.asarray(channel.pixels, dtype=np.float32)
    except Exception as exc:  # OpenEXR raises its own types for a damaged file
        raise CompareError(f"{path}: unreadable OpenEXR ({exc})") from None
    if not channels:
        raise CompareError(f"{path}: holds no channels")
    rendered = header.get("volcaustics_scene_hash")
    if isinstance(rendered, str) and rendered != scene.scene_hash():
        raise CompareError(f"{path}: rendered from scene {header.get('volcaustics_scene', '?')!r} (hash "
                           f"{rendered[:12]}), not {scene.name!r} (hash {scene.scene_hash()[:12]}): compare it with "
                           f"the scene it shows")
    shapes = {c.shape for c in channels.values()}
    if len(shapes) != 1 or len(next(iter(shapes))) != 2:
        raise CompareError(f"{path}: its parts or channels differ in size ({sorted(shapes)}): write one image size "
                           f"with every channel sampled per pixel")
    return channels


def _check_size(path: str, width: int, height: int, scene) -> None:
    cw, ch = scene.camera.width, scene.camera.height
    if width * ch != height * cw:
        raise CompareError(f"{path}: {width}×{height} pixels, but {scene.name}'s camera is {cw}×{ch}: render at "
                           f"{cw}×{ch} or another size of the same aspect ratio (the vertical field of view fixes "
                           f"the pixels' solid angles)")


def _rgb(channels: dict, layer: str) -> bool:
    prefix = f"{layer}." if layer else ""
    return all(f"{prefix}{c}" in channels for c in "RGB")


def _layers(path: str, channels: dict) -> tuple:
    """The layers of a file: the summed ones (all or none), ``combined`` (a layer or the
    root channels), ``mask_specular`` when there."""
    have = [layer for layer in SUMMED if _rgb(channels, layer)]
    if have and len(have) < len(SUMMED):
        missing = [layer for layer in SUMMED if layer not in have]
        raise CompareError(f"{path}: has {', '.join(have)} but no {', '.join(missing)} (channels "
                           f"{missing[0]}.R, .G, .B): give every one of {', '.join(SUMMED)}, or only root R, G, B "
                           f"(compared as combined)")
    partial = sorted({name.rsplit(".", 1)[0] for name in channels if "." in name
                      and name.rsplit(".", 1)[0] in (*SUMMED, ROOT) and not _rgb(channels, name.rsplit(".", 1)[0])})
    if partial:
        raise CompareError(f"{path}: layer {partial[0]} lacks some of its R, G, B channels")
    layers = list(have)
    if _rgb(channels, ROOT) or _rgb(channels, ""):
        layers.append(ROOT)
    if not layers:
        names = ", ".join(sorted(channels)[:8])
        raise CompareError(f"{path}: no caustic/fog/direct layers and no root R, G, B channels (it has {names}): "
                           f"compare needs {CONVENTION}")
    if f"{MASK_LAYER}.Y" in channels or f"{MASK_LAYER}.R" in channels:
        layers.append(MASK_LAYER)
    return tuple(layers)


def _frame_images(path: str, channels: dict, layers: tuple, warnings: list) -> dict:
    images, used = {}, set()
    for layer in layers:
        if layer == MASK_LAYER:
            name = f"{MASK_LAYER}.Y" if f"{MASK_LAYER}.Y" in channels else f"{MASK_LAYER}.R"
            images[layer] = np.repeat(channels[name][..., None], 3, axis=2)
            used.add(name)
            continue
        prefix = f"{layer}." if _rgb(channels, layer) else ""
        images[layer] = np.stack([channels[f"{prefix}{c}"] for c in "RGB"], axis=-1)
        used.update(f"{prefix}{c}" for c in "RGB")
    unread = sorted(name for name, values in channels.items() if name not in used and not np.isfinite(values).all())
    if unread:  # not compared, but a renderer that writes NaN somewhere should hear of it
        warnings.append(f"{os.path.basename(path)}: channel(s) {', '.join(unread)} hold NaN or ∞ (not compared)")
    for layer, image in images.items():
        bad = ~np.isfinite(image)
        if bad.any():
            y, x, _ = np.argwhere(bad)[0]
            raise CompareError(f"{path}: layer {layer} has {int(bad.any(axis=2).sum())} pixel(s) with NaN or ∞ "
                               f"(the first at row {y}, column {x}): a renderer's image must be finite")
        if layer == MASK_LAYER and ((image < 0) | (image > 1)).any():
            y, x, _ = np.argwhere((image < 0) | (image > 1))[0]
            raise CompareError(f"{path}: layer {MASK_LAYER} has a value outside [0, 1] (the first at row {y}, column "
                               f"{x}: {float(image[y, x, 0]):.3g}): it is 1 where the camera sees glass, else 0")
        negative = image < 0
        if layer != MASK_LAYER and negative.any():
            y, x, _ = np.argwhere(negative)[0]
            raise CompareError(f"{path}: layer {layer} has {int(negative.any(axis=2).sum())} negative pixel(s) "
                               f"(the first at row {y}, column {x}, {float(image[y, x].min()):.3g}): radiance is ≥ 0; "
                               f"render with a box pixel filter (a filter with negative lobes rings)")
    if SUMMED[0] in images:
        total = cast(np.ndarray, sum(images[layer] for layer in SUMMED))
        if ROOT in images:
            scale = float(np.abs(total).sum()) or 1.0
            off = float(np.abs(images[ROOT] - total).sum()) / scale
            if off > COMBINED_TOLERANCE:
                warnings.append(f"{os.path.basename(path)}: combined differs from caustic + fog + direct by "
                                f"{100 * off:.2f}% of their sum (compared as given)")
        else:
            images[ROOT] = total
    if MASK_LAYER not in images:
        images[MASK_LAYER] = np.zeros_like(next(iter(images.values())))
    return images
