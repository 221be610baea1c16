"""Reference renders: every component in independent batches, with per-pixel
variance of the mean, served from and stored to the cache.

Layers (DESIGN.md names) and their variances: ``caustic`` (light tracer),
``fog`` and ``direct`` (single-scatter camera integrator), ``combined`` (their
sum, per batch, so its variance includes the correlation of fog and direct),
``mask_specular``; ``<layer>_var`` holds the variance of the mean.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from scenes.formats import COLOUR_LAYERS, MASK_LAYER
from scenes.imageio import png_bytes, tonemap_srgb8

from . import cache
from .request import RenderRequest, resolve
from .settings import ReferenceSettings


class ReferenceResult:
    """A cached reference: ``manifest`` (photons, batches, seed, wall time, variant,
    versions, the caller's scene name and hash, settings, cached), ``exr_path``/``png_path`` of the cache
    files, and the images, read on first use: ``mean`` (layer → H×W×3 float32;
    mask_specular 0/1) and ``var`` (layer → variance of the mean)."""

    def __init__(self, key: str, manifest: dict, cached: bool, layers: dict | None = None):
        self.key, self.manifest, self.cached = key, {**manifest, "cached": cached}, cached
        self.exr_path, _ = cache.paths(key)
        self.png_path = self.exr_path[:-4] + ".png"
        self._layers = layers

    def _load(self) -> dict:
        if self._layers is None:
            self._layers = cache.read_layers(self.key)
        return self._layers

    @property
    def mean(self) -> dict:
        return {k: v for k, v in self._load().items() if not k.endswith("_var")}

    @property
    def var(self) -> dict:
        return {k[:-4]: v for k, v in self._load().items() if k.endswith("_var")}


class _Welford:
    def __init__(self):
        self.n, self.mean, self.m2 = 0, None, None

    def add(self, x: np.ndarray):
        x = x.astype(np.float64)
        self.n += 1
        if self.mean is None:
            self.mean, self.m2 = x.copy(), np.zeros_like(x)
            return
        delta = x - self.mean
        self.mean += delta / self.n
        self.m2 += delta * (x - self.mean)

    def result(self):
        return self.mean.astype(np.float32), (self.m2 / (self.n - 1) / self.n).astype(np.float32)


def render_batches(scene, settings: ReferenceSettings, *, mode: str = "caustic", progress: bool = True) -> dict:
    """Render without the cache; returns {layer: (mean, var)} for the colour layers
    and the mask, plus timing and counts under the key ``"_info"``."""
    return _render(resolve(scene, settings, mode), progress=progress)


def _render(request: RenderRequest, *, progress: bool) -> dict:
    from tqdm import tqdm

    from .export import mitsuba_dict
    from .integrators import SingleScatterIntegrator, VolumetricLightTracer, configure
    from .mi_setup import mitsuba

    mi = mitsuba()
    scene, settings = request.scene, request.settings
    t0 = time.perf_counter()
    mi_scene = mi.load_dict(mitsuba_dict(request.description))
    props = mi.Properties()
    props["mode"] = request.mode
    props["max_scatter"] = settings.max_scatter
    tracer = configure(VolumetricLightTracer(props), scene, mi_scene)
    camera = configure(SingleScatterIntegrator(), scene, mi_scene)
    pixels = settings.width * settings.height
    photon_spp = max(1, math.ceil(settings.photons / settings.batches / pixels))
    camera_spp = settings.spp // settings.batches
    acc = {name: _Welford() for name in COLOUR_LAYERS}
    mask = None
    for b in tqdm(range(settings.batches), desc=f"reference {scene.name}", unit="batch", disable=not progress):
        seed = settings.seed * settings.batches + b
        caustic = np.asarray(mi.render(mi_scene, integrator=tracer, seed=seed, spp=photon_spp))[..., :3]
        cam = np.asarray(mi.render(mi_scene, integrator=camera, seed=seed, spp=camera_spp))
        fog, direct = cam[..., 3:6], cam[..., 6:9]
        mask = cam[..., 9:10] > 0.5 if mask is None else mask | (cam[..., 9:10] > 0.5)
        for name, image in (("caustic", caustic), ("fog", fog), ("direct", direct),
                            ("combined", caustic + fog + direct)):
            acc[name].add(image)
    out = {name: acc[name].result() for name in COLOUR_LAYERS}
    m = np.repeat(mask.astype(np.float32), 3, axis=2)
    out[MASK_LAYER] = (m, np.zeros_like(m))
    out["_info"] = {"seconds": time.perf_counter() - t0, "photons": photon_spp * pixels * settings.batches,
                    "photon_spp_per_batch": photon_spp, "camera_spp_per_batch": camera_spp}
    return out


def render_reference(scene, settings: ReferenceSettings | None = None, *, mode: str = "caustic",
                     force: bool = False, progress: bool = True) -> ReferenceResult:
    """The reference for ``scene``: from the cache when a valid entry exists (and not
    ``force``), else rendered and stored. The image is ``settings.width × height``
    (unset: the scene camera's); the camera's own size does not matter beyond that.
    ``mode``: which light paths the caustic layer counts (settings.MODES)."""
    from .mi_setup import drjit_version, mitsuba_version, variant_name

    request = resolve(scene, settings, mode)
    settings = request.settings
    if not force:
        served = cache.lookup(request)
        if served is not None:
            key, manifest = served
            return ReferenceResult(key, _for_caller(manifest, scene), cached=True)
    out = _render(request, progress=progress)
    key = cache.request_key(request, variant_name())
    info = out.pop("_info")
    layers = {}
    for name, (mean, var) in out.items():
        layers[name] = mean
        if name != MASK_LAYER:
            layers[f"{name}_var"] = var
    manifest = {
        "scene": scene.name, "scene_hash": scene.scene_hash(), "settings": settings.to_dict(), "mode": request.mode,
        "photons": info["photons"], "batches": settings.batches, "seed": settings.seed,
        "camera_spp": info["camera_spp_per_batch"] * settings.batches, "wall_seconds": info["seconds"],
        "mitsuba_variant": variant_name(), "mitsuba_version": mitsuba_version(), "drjit_version": drjit_version(),
        "reference_code_version": cache.code_version(),
    }
    header = {"volcaustics_scene": scene.name, "volcaustics_scene_hash": scene.scene_hash(),
              "volcaustics_renderer": "reference", "volcaustics_manifest": json.dumps(manifest, default=float)}
    manifest = cache.store(key, layers, manifest, header, png_bytes(tonemap_srgb8(layers["combined"])))
    return ReferenceResult(key, manifest, cached=False, layers=layers)


def _for_caller(manifest: dict, scene) -> dict:
    """A cached manifest with the caller's scene name and hash: one entry serves every
    scene that renders the same (other labels, another camera size with settings naming
    the size), and the caller is told about the scene it passed."""
    return {**manifest, "scene": scene.name, "scene_hash": scene.scene_hash()}
