"""Exact photons through the approximation's splatter: the caustic images E_k and E_∞
of docs/concepts/measuring.md: images).

The approximation's photons are replayed from their emission state (its step-1
records) with exact intersections and the very same random numbers
(``reference.oracle.exact_photon_records``); every medium collision is then
splatted by the approximation's own splatter (``approx.Renderer.splat``): the
same view, G-buffer depth test, kernel, medium weights and phase. What differs
from the approximation's own caustic is the intersection estimation alone (and
``steps``, ``fresnel`` when chosen differently).

Noise: every photon draws its own random numbers (``scenes.rng``, keyed by the
photon index), so photon subsets are independent. The photons are split into
``batches`` subsets of interleaved emission texels (each covers the whole light
on a coarser grid, :func:`interleaved_subsets`); each subset's image times K is an
independent estimate of the caustic, and their spread gives the variance of the
mean per pixel. :func:`reference_caustic` gives the reference's caustic in the
same form (independent batch images), so that ``metrics.noise`` can compare the
two with their noise.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from volcaustics.approx import Renderer
from volcaustics.approx.splat import record_splats, splatted
from volcaustics.approx.splat_modes import splat_mode
from volcaustics.reference.oracle import Oracle, exact_photon_records
from volcaustics.reference.render import render_batches
from volcaustics.scenes.formats import STATUS_COLLIDED, STATUS_SURFACE

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes.model import Camera, Scene


@dataclass
class ExactPhotons:
    """Every medium collision of the exact replay, ready to splat.

    splats: N rows of ``scenes.formats.SPLAT_DTYPE`` (collision point in metres,
        unit direction before scattering, RGB power in W after transmittance); with
        splat = beams BEAM_DTYPE rows, the replay's segments in the medium.
    photon: N photon indices (emission texel, uint32) of the splats.
    step: N interaction steps (1..steps) of the splats.
    emitted_power: RGB power (W) of the replayed photons at their start, after the
        emission's first specular interaction.
    alive_power: RGB power (W) still travelling after the last step (neither
        collided-and-continued nor at a surface counts as ended).
    collided_power: steps×3, RGB power (W) splatted per step.
    photons: number of photons replayed.
    params: what produced them: the approximation's resolved parameters (seed,
        photon_res, the emission's fresnel), the replay's ``steps`` and ``fresnel``.
    """

    splats: np.ndarray
    photon: np.ndarray
    step: np.ndarray
    emitted_power: np.ndarray
    alive_power: np.ndarray
    collided_power: np.ndarray
    photons: int
    params: dict
    mask_specular: np.ndarray | None = None

    @property
    def alive_fraction(self) -> float:
        """Largest per-channel share of the start power still alive after the last step."""
        emitted = np.maximum(self.emitted_power, 1e-300)
        return float(np.max(self.alive_power / emitted))


@dataclass
class BatchImages:
    """K independent unbiased estimates of one image (``batch_images``, K×H×W×3
    float32) and the glass mask (``mask_specular``, H×W×3 float32, 1 on glass): their
    mean, its per-pixel variance and the variance of sums over pixels."""

    batch_images: np.ndarray
    mask_specular: np.ndarray | None

    @property
    def batches(self) -> int:
        return len(self.batch_images)

    @property
    def mean(self) -> np.ndarray:
        """H×W×3 float32: the mean of the batches."""
        return self.batch_images.astype(np.float64).mean(axis=0).astype(np.float32)

    @property
    def var(self) -> np.ndarray:
        """H×W×3 float32: per-pixel variance of :attr:`mean` over the batches."""
        b = self.batch_images.astype(np.float64)
        return (b.var(axis=0, ddof=1) / len(b)).astype(np.float32)

    def total(self, mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """RGB sum over the pixels of ``mask`` (H×W bool; all pixels when None): its
        value and the variance of that value, from the batches' totals (so the
        covariance of neighbouring pixels, which one splat shares, is included)."""
        b = self.batch_images.astype(np.float64)
        sums = b[:, mask].sum(axis=1) if mask is not None else b.sum(axis=(1, 2))
        return sums.mean(axis=0), sums.var(axis=0, ddof=1) / len(sums)


@dataclass
class ExactCaustic(BatchImages):
    """The exact photons' caustic in independent batches.

    batch_images: K×H×W×3 float32, linear Rec.709 radiance (W·m⁻²·sr⁻¹), row 0 at the
        top; image k is K times the caustic of the photons of subset k
        (:func:`interleaved_subsets`): K independent unbiased estimates of the same image.
    mask_specular: H×W×3 float32, 1 where the camera sees glass (the approximation's
        G-buffer), else 0.
    photons: the :class:`ExactPhotons` splatted.
    params: the parameters actually used (``photons.params`` plus batches, splat_radius,
        width, height and the phase the splats were weighted with).
    """

    photons: ExactPhotons | None = None
    params: dict = field(default_factory=dict)


def exact_photons(scene: Scene, params: ApproxParams, *, steps: int, fresnel: str, renderer: Renderer | None = None,
                  oracle: Oracle | None = None, first_records: np.ndarray | None = None) -> ExactPhotons:
    """Replay the approximation's photons exactly and collect their medium collisions.

    Parameters
    ----------
    scene : the scene (``scenes.model.Scene``).
    params : ``approx.ApproxParams``: photon_res, light_res, seed and image size of the
        frame whose emission is replayed.
    steps : interaction steps of the replay (E_∞ wants so many that < 0.1% of the power
        is alive afterwards: check :attr:`ExactPhotons.alive_fraction`).
    fresnel : "deterministic" or "stochastic", for the emission and the replay.
    renderer : an ``approx.Renderer`` of ``scene`` to reuse (else one is made).
    oracle : a ``reference.oracle.Oracle`` of ``scene`` to reuse (else one is made).
    first_records : the emission state to replay (step-1 records, RECORD_DTYPE) when
        already at hand; else a one-step frame is rendered for it.
    """
    p = dataclasses.replace(params, fresnel=fresnel).resolved(scene)
    mask = None
    if first_records is None:
        own = renderer is None
        renderer = renderer or Renderer(scene)
        try:
            # one step: its records hold the emission state; fog_steps 1: the frame's images are unused
            frame = renderer.render(scene, dataclasses.replace(p, steps=1, fog_steps=1), keep_records=True)
        finally:
            if own:
                renderer.release()
        first_records = frame.records[0]
        mask = frame.images["mask_specular"]
    records = exact_photon_records(scene, first_records, steps=steps, seed=p.seed, fresnel=fresnel,
                                   oracle=oracle or Oracle(scene), beams=splat_mode(p).beams,
                                   splits=p.fresnel_splits, slots=p.photon_res**2)
    return photons_from_records(records, first_records, p, steps=steps, fresnel=fresnel, mask_specular=mask)


def photons_from_records(records: list, first_records: np.ndarray, params: ApproxParams, *, steps: int,
                         fresnel: str, mask_specular: np.ndarray | None = None) -> ExactPhotons:
    """The medium collisions of an exact replay's per-step records
    (``reference.oracle.exact_photon_records``) as :class:`ExactPhotons`, for callers
    that also use the records (power budgets, divergence)."""
    collided = [r[splatted(r, params)] for r in records]
    collided_power = np.zeros((steps, 3))
    power = "power_start" if splat_mode(params).beams else "power"  # what is splatted: beams carry their start's
    for k, c in enumerate(collided):
        collided_power[k] = c[power].astype(np.float64).sum(axis=0)
    rows = np.concatenate(collided) if collided else np.zeros(0, first_records.dtype)
    last = records[-1] if len(records) == steps else None  # shorter: every photon ended early
    alive = np.zeros(3)
    if last is not None:
        keep = (last["status"] == STATUS_SURFACE) | (last["status"] == STATUS_COLLIDED)
        alive = last["power"][keep].astype(np.float64).sum(axis=0)
    used = {**params.to_dict(), "steps": steps, "fresnel": fresnel, "emission_fresnel": fresnel}
    return ExactPhotons(splats=record_splats(rows, params.splat),
                        photon=rows["photon"].astype(np.uint32), step=rows["step"].astype(np.int64),
                        emitted_power=first_records["power_start"].astype(np.float64).sum(axis=0),
                        alive_power=alive, collided_power=collided_power, photons=len(first_records),
                        params=used, mask_specular=mask_specular)


def interleaved_subsets(photon: np.ndarray, photon_res: int, batches: int) -> np.ndarray:
    """Subset (0..batches−1) of each photon: emission texel (row mod a, column mod b),
    a·b = batches with a the largest divisor ≤ √batches. Each subset is the emission
    grid at a (b) times its spacing, stratified over the light like the whole grid, so
    the subsets' spread measures the noise of the whole; subsets of whole columns
    (index mod K) differ in the light they cover and overstated the standard
    deviation of the energy 2× (sphere1, 8 seeds). A photon slot of a split batch
    (``scenes.splitting``: b·photon_res² + texel) is its texel's: the batches of one
    photon stay in one subset."""
    a = max(d for d in range(1, int(np.sqrt(batches)) + 1) if batches % d == 0)
    b = batches // a
    photon = np.asarray(photon, np.int64) % (photon_res * photon_res)
    return ((photon // photon_res) % a) * b + (photon % photon_res) % b


def pixel_footprint(camera: Camera, height: int, distance: float | None = None) -> float:
    """Width (m) of one pixel of an image ``height`` pixels tall, at ``distance`` (m,
    default: the camera's target distance) along the view axis: the pinhole's vertical
    field of view over the rows."""
    if distance is None:
        distance = float(np.linalg.norm(np.subtract(camera.target, camera.position)))
    return 2.0 * distance * float(np.tan(np.radians(camera.fov_y) / 2.0)) / height


def box_downsample(image: np.ndarray, factor: int, reduce: Callable[..., Any] = np.mean) -> np.ndarray:
    """H·f×W·f×C → H×W×C: each output pixel reduces (mean: the box filter) its f×f block."""
    if factor == 1:
        return image
    h, w = image.shape[0] // factor, image.shape[1] // factor
    blocks = image.reshape(h, factor, w, factor, *image.shape[2:])
    return reduce(blocks, axis=(1, 3)).astype(image.dtype)


def subset_images(renderer: Renderer, splats: np.ndarray, photon: np.ndarray, photon_res: int, batches: int,
                  params: ApproxParams, scene: Scene | None = None, *,
                  supersample: int = 1) -> np.ndarray:
    """K × H × W × 3 float32: photon subset k's caustic (:func:`interleaved_subsets`)
    times K, through ``renderer``'s splatter: K independent unbiased estimates of the
    caustic of all the photons (their mean). Subsets of different photon sets of one
    emission grid (the approximation's, its exact replays) are paired: subset k holds
    the same emission texels in each. ``supersample``: splat at S× the size and average
    S×S blocks (the reference's box filter)."""
    p = params.resolved(scene or renderer.scene)
    fine = dataclasses.replace(p, width=cast(int, p.width) * supersample, height=cast(int, p.height) * supersample)
    subset = interleaved_subsets(photon, photon_res, batches)
    images = renderer.splat_many([splats[subset == k] for k in range(batches)], scene, fine)
    return np.stack([box_downsample(image, supersample) * np.float32(batches) for image in images]).astype(np.float32)


def exact_caustic(scene: Scene, params: ApproxParams, *, steps: int, fresnel: str, batches: int = 8,
                  supersample: int = 1, renderer: Renderer | None = None, oracle: Oracle | None = None,
                  photons: ExactPhotons | None = None,
                  with_mask: bool = True) -> ExactCaustic:
    """E_k / E_∞: the exact photons' caustic through the approximation's splatter.

    Parameters
    ----------
    scene : the scene; its medium's phase weights the splats (``photons`` traced in a
        scene that differs only in the phase may be splatted here).
    params : ``approx.ApproxParams``; photon_res, light_res, seed select the photons,
        splat_radius, width, height the image.
    steps, fresnel : see :func:`exact_photons` (ignored when ``photons`` is given).
    batches : K ≥ 2 independent photon subsets (:func:`interleaved_subsets`) for the variance.
    supersample : S ≥ 1: splat at S·width × S·height and average S×S blocks, which
        gives each pixel the reference's box filter (docs/conventions.md) instead
        of the approximation's point sample at the pixel centre. A kernel narrower
        than about half a fine pixel aliases (the fine samples miss thin caustics).
    renderer, oracle : reused when given.
    photons : an earlier :func:`exact_photons` result to splat again (another kernel,
        phase or image size) without retracing.
    with_mask : False skips rendering the glass mask at the fine size when the photons
        do not carry it (``mask_specular`` is then None unless they do).

    Returns
    -------
    :class:`ExactCaustic` at width × height: batch images, mean, per-pixel variance of
    the mean, the glass mask (1 where any fine sample sees glass), the photons (alive
    power after the last step) and the parameters used.
    """
    if batches < 2:
        raise ValueError(f"batches = {batches}: expected at least 2 (the variance needs two)")
    if isinstance(supersample, bool) or not isinstance(supersample, int) or supersample < 1:
        raise ValueError(f"supersample = {supersample!r}: expected an integer >= 1")
    p = params.resolved(scene)
    fine = dataclasses.replace(p, width=cast(int, p.width) * supersample, height=cast(int, p.height) * supersample)
    own = renderer is None
    renderer = renderer or Renderer(scene)
    try:
        if photons is None:
            photons = exact_photons(scene, fine, steps=steps, fresnel=fresnel, renderer=renderer, oracle=oracle)
        images = subset_images(renderer, photons.splats, photons.photon, photons.params["photon_res"], batches, p,
                               scene, supersample=supersample)
        mask = photons.mask_specular
        if mask is not None and mask.shape[:2] != (fine.height, fine.width):
            mask = None
        if with_mask and mask is None:
            mask = renderer.render(scene, dataclasses.replace(fine, steps=1, photon_res=1, fog_steps=1),
                                   keep_records=False).images["mask_specular"]
    finally:
        if own:
            renderer.release()
    phase = scene.medium.phase
    used = {**photons.params, "batches": batches, "supersample": supersample, "splat_radius": p.splat_radius,
            "width": p.width, "height": p.height, "phase": phase.kind,
            "g": float(phase.g) if phase.kind == "hg" else 0.0}
    return ExactCaustic(batch_images=images,
                        mask_specular=None if mask is None else box_downsample(mask, supersample, np.max),
                        photons=photons, params=used)


@dataclass
class ReferenceCaustic(BatchImages):
    """The reference's caustic as independent batch images.

    batch_images: L×H×W×3 float32, linear Rec.709 radiance, row 0 at the top: L
        independent unbiased estimates of the reference caustic (each the mean of one
        ``reference.render.render_batches`` call of two Mitsuba batches).
    mask_specular: H×W×3 float32, 1 where any camera sample saw glass, else 0.
    params: the settings actually used (per call and in total), the mode, seconds.
    """

    params: dict = field(default_factory=dict)


def reference_caustic(scene: Scene, settings: ReferenceSettings, *, mode: str = "caustic") -> ReferenceCaustic:
    """The reference caustic in ``settings.batches`` independent batch images (uncached).

    ``reference.render.render_batches`` keeps only each pixel's mean and variance;
    comparisons that need the reference's batches (the variance of its total, a
    distribution-free standard error, ``metrics.noise``) get them here from
    ``settings.batches`` calls of two batches each, ``settings.photons`` and
    ``settings.spp`` shared among them, with seeds that never repeat
    (call ℓ: ``settings.seed · L + ℓ``).
    """
    calls = settings.batches
    t0 = time.perf_counter()
    per_call = dataclasses.replace(settings, batches=2, photons=max(1, settings.photons // calls),
                                   spp=max(2, settings.spp // calls))
    images, mask, photons = [], None, 0
    for call in range(calls):
        out = render_batches(scene, dataclasses.replace(per_call, seed=settings.seed * calls + call), mode=mode,
                             progress=False)
        images.append(out["caustic"][0])
        m = out["mask_specular"][0]
        mask = m if mask is None else np.maximum(mask, m)
        photons += out["_info"]["photons"]
    used = {**settings.to_dict(), "mode": mode, "photons": photons, "calls": calls,
            "per_call": per_call.to_dict(), "seconds": time.perf_counter() - t0}
    return ReferenceCaustic(batch_images=np.stack(images).astype(np.float32), mask_specular=mask, params=used)
