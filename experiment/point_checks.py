"""What an experiment can measure, checked before any reference renders: the seeds, a
frame that fits the GL driver and this machine (``approx.limits.check_fits``, with the
small-kernel image drawn at ``SMALL_SUPERSAMPLE``× per side), an image every metric can
read and the memory a whole measurement holds."""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from volcaustics.approx.limits import check_fits
from volcaustics.approx.params import ParamError, preset
from volcaustics.experiment.exact_images import SMALL_SUPERSAMPLE
from volcaustics.infra.memory import image_fits
from volcaustics.metrics.image import SSIM_WINDOW

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.scenes.model import Scene

# What a measurement holds per pixel (both renders, the reference, the decomposition's
# subset images at 16× the pixels, every metric): 2.9 kB + 0.65–0.84 kB per seed measured
# as peak RSS per pixel, rounded up (bench/image_memory.py, docs/decisions.md "Image sizes
# against memory").
BYTES_PER_PIXEL = 3000
BYTES_PER_PIXEL_PER_SEED = 850


def check_frame(p: ApproxParams, seeds: int) -> None:
    """ParamError unless ``p`` (width/height resolved) can be measured with ``seeds`` seeds."""
    for name in ("width", "height"):
        size = getattr(p, name)
        if size < SSIM_WINDOW:
            raise ParamError(f"{name} = {size}: a measurement needs images of at least {SSIM_WINDOW} × "
                             f"{SSIM_WINDOW} pixels (SSIM's Gaussian window, σ 1.5); {name} ≥ {SSIM_WINDOW}")
    check_fits(p, keep_records=True, supersample=SMALL_SUPERSAMPLE)
    check_images_fit(cast(int, p.width), cast(int, p.height), seeds, (BYTES_PER_PIXEL, BYTES_PER_PIXEL_PER_SEED),
                     f"the images of a measurement with {seeds} seed(s) (both renders, the reference, "
                     f"the error decomposition's at {SMALL_SUPERSAMPLE}× per side)")


def measurement_bytes(width: int, height: int, seeds: int) -> int:
    """What the images of one measurement with ``seeds`` seeds at width × height hold."""
    return width * height * (BYTES_PER_PIXEL + BYTES_PER_PIXEL_PER_SEED * seeds)


def check_images_fit(width: int, height: int, seeds: int, cost: tuple, what: str) -> None:
    """ParamError unless the images of a command that measures ``seeds`` frames at width ×
    height fit this machine's memory: ``cost`` is its (bytes per pixel, bytes per pixel
    per seed), measured by ``bench/image_memory.py`` (``measure``: BYTES_PER_PIXEL and
    BYTES_PER_PIXEL_PER_SEED; ``compare``: its own). The one check of ``measure`` and
    ``compare``, run before any reference renders."""
    reason = image_fits(width, height, cost[0] + cost[1] * seeds, what)
    if reason:
        raise ParamError(f"{reason}, or fewer seeds")


# Beyond this optical depth (light → target → eye) single scattering reaches the camera
# attenuated by e^-τ < 2^-34: fewer than one photon of the largest reference (max_photons
# 2^34) would carry the caustic: docs/decisions.md "A medium a measurement can measure".
MAX_OPTICAL_DEPTH = 24.0


def check_medium(scene: Scene) -> None:
    """ParamError unless ``scene``'s medium gives a volume caustic to measure: it scatters
    in every colour channel (the error's shares divide by the reference caustic, per
    channel) and its optical depth leaves the camera some light (MAX_OPTICAL_DEPTH).
    Checked before any reference renders."""
    from volcaustics.scenes.fields import optical_depth

    sigma_s = scene.medium.sigma_s
    if min(sigma_s) <= 0.0:
        raise ParamError(f"{scene.name}: medium.sigma_s = {list(sigma_s)}: a channel without scattering has no volume "
                    f"caustic to measure (the error is relative to the reference's caustic in each channel); "
                    f"give every channel sigma_s > 0")
    depth = optical_depth(scene)
    if not depth <= MAX_OPTICAL_DEPTH:
        raise ParamError(f"{scene.name}: the medium's optical depth from the light to the camera is {depth:.3g} "
                    f"(sigma_t {scene.medium.sigma_bar:.3g} 1/m over the light → target → eye path), above "
                    f"{MAX_OPTICAL_DEPTH:g}: e^-{depth:.3g} leaves no light a reference can render for the "
                    f"camera; give a thinner medium")


def check_denoiser(params: ApproxParams) -> None:
    """ParamError before any work when ``params`` ask for a denoiser this machine cannot
    load (``denoise = oidn`` without a loadable OIDN binding: it failed mid-render)."""
    if params.denoise == "oidn":
        from volcaustics.approx.denoise import unavailable

        reason = unavailable()
        if reason:
            raise ParamError(f"denoise = oidn: {reason}; install it (pip install pyoidn) or use denoise = none")


def checked_settings(scene: Scene, params: ApproxParams, seeds: int) -> tuple:
    """(resolved params, seed list); ParamError before any work for a bad seed count,
    a frame that cannot be measured, a denoiser that cannot load (:func:`check_denoiser`)
    or a medium without a caustic (:func:`check_medium`)."""
    check_medium(scene)
    check_denoiser(params)
    if isinstance(seeds, bool) or not isinstance(seeds, int) or not 1 <= seeds <= 1024:
        raise ParamError(f"seeds = {seeds!r}: expected an integer in [1, 1024]")
    p = params.resolved(scene)
    if p.seed + seeds - 1 > 2**32 - 1:
        raise ParamError(f"seed = {p.seed} with seeds = {seeds}: the last seed exceeds 2^32 − 1")
    check_frame(p, seeds)  # before the reference: a frame that cannot run fails at once
    return p, [p.seed + i for i in range(seeds)]


def measured_settings(preset_name: str, overrides: dict, *, seeds: int, seed: int, min_seeds: int, why: str) -> tuple:
    """(params, seeds) of a gate's or a report's experiments: the preset with
    ``overrides`` and first seed ``seed``; ``seeds`` at least ``min_seeds`` (``why``
    says why). ParamError for a bad override, seed count or seed; a frame that cannot
    be measured fails here, before any reference renders."""
    if isinstance(seeds, bool) or not isinstance(seeds, int) or not min_seeds <= seeds <= 256:
        raise ParamError(f"--seeds = {seeds!r}: expected an integer in [{min_seeds}, 256] ({why})")
    if not 0 <= seed <= 2**32 - seeds:
        raise ParamError(f"--seed = {seed}: expected 0 ≤ seed and seed + seeds − 1 < 2^32")
    try:
        params = preset(preset_name, seed=seed, **overrides)
        check_frame(params, seeds)
    except ParamError as exc:
        raise ParamError(f"--set: {exc}") from None
    return params, seeds
