"""Settings of a reference render (names as on the CLI)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, cast

from volcaustics.infra.errors import InputError
from volcaustics.infra.memory import image_fits

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

# which light paths the light tracer counts (reference.integrators); "orders" is the
# higher-orders stream's own (max_scatter > 1), not a mode a reference is requested in
MODES = ("caustic", "fog", "all", "surface", "orders")
REQUEST_MODES = MODES[:-1]
# components with a noise floor (combined is their sum); the model term's (max_scatter > 1):
# its variance over Σ R_ms², reference.render.orders
NOISE_COMPONENTS = ("caustic", "fog", "direct", "caustic_ms", "fog_ms", "direct_ms")
MAX_SAMPLES_PER_RENDER = 2**32  # Mitsuba's limit for one render (its wavefront sample index is 32-bit)
# The reference's film, batch sums, mean/variance layers and EXR per pixel: 642 B measured
# as peak RSS per pixel, rounded up (bench/image_memory.py, docs/decisions.md "Image sizes against memory").
IMAGE_BYTES_PER_PIXEL = 700
# Size-independent settings: they say how long to render, not what one batch is, so they
# are not part of a cache entry's identity (an entry is continued batch by batch).
BUDGET_FIELDS = ("photons", "spp", "batches", "target_noise", "max_photons", "max_seconds")
# The orders stream's batches trace a quarter of the light tracer's paths per pixel: at the
# report's 16 batches its floors sat 5–300× under their 0.5% targets while it took ~60% of
# a reference's time (docs/history.md "Harness speed"); the targets add batches where needed.
ORDERS_SHARE = 4


class SettingsError(InputError):
    """A reference setting is out of range; the message names it and what is allowed."""


@dataclass(frozen=True)
class ReferenceSettings:
    """photons: light paths of the caustic light tracer, over ``batches`` batches.
    spp: camera samples per pixel of the fog/direct integrator, over ``batches`` batches.
    batches: independent batches per stream (light tracer, camera integrator), for the
        per-pixel variance; photons/batches and spp/batches make one batch.
    target_noise: None renders exactly ``batches`` batches. Else ((component, floor), ...)
        over NOISE_COMPONENTS: batches (at least ``batches``) are added to each stream until
        every listed component's noise floor is at most its target, or a cap is reached.
    max_photons, max_seconds: the caps of a target_noise render (photons over the
        entry's light batches; seconds of this call).
    max_scatter: 1 = single scattering (the paper's model); more for multiple scattering.
    width, height: None takes the scene camera's.
    seed: batch b of each stream renders with a seed hashed from (seed, stream, b)."""

    photons: int = 1 << 24
    spp: int = 256
    batches: int = 8
    max_scatter: int = 1
    width: int | None = None
    height: int | None = None
    seed: int = 0
    target_noise: tuple | None = None
    max_photons: int = 1 << 34
    max_seconds: float = 600.0

    def __post_init__(self):
        checks = {"photons": (1, 1 << 40), "spp": (1, 1 << 20), "batches": (2, 4096), "max_scatter": (1, 64),
                  "seed": (0, 2**31 - 1)}
        for name, (lo, hi) in checks.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise SettingsError(f"{name} = {v!r}: expected an integer in [{lo}, {hi}]")
        for name in ("width", "height"):
            v = getattr(self, name)
            if v is not None and (isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 16384):
                raise SettingsError(f"{name} = {v!r}: expected an integer in [1, 16384] (or unset: the scene's)")
        if self.spp < self.batches:
            raise SettingsError(f"spp = {self.spp}: expected at least one sample per batch (batches = {self.batches})")
        if isinstance(self.max_photons, bool) or not isinstance(self.max_photons, int) or self.max_photons < 1:
            raise SettingsError(f"max_photons = {self.max_photons!r}: expected a positive integer")
        if isinstance(self.max_seconds, bool) or not isinstance(self.max_seconds, (int, float)) \
                or not self.max_seconds > 0:
            raise SettingsError(f"max_seconds = {self.max_seconds!r}: expected a positive number of seconds")
        if self.target_noise is not None:
            object.__setattr__(self, "target_noise", parse_target_noise(self.target_noise))

        if self.width is not None and self.height is not None:
            reason = image_fits(self.width, self.height, IMAGE_BYTES_PER_PIXEL, "the reference's film and layers")
            if reason:
                raise SettingsError(reason)
            self._check_samples_per_render()
        self._check_photon_cap()

    def _check_photon_cap(self) -> None:
        """With a noise target, ``max_photons`` must be at least the photons every render
        draws (``batches`` light batches; unsized, ``photons``): the cap limits the batches
        the target adds beyond them, so a cap below (below one batch: ``--max-photons 1``)
        could never stop anything and passed silently."""
        if self.target_noise is None:
            return
        sized = self.width is not None and self.height is not None
        least = self.batches * self.photons_per_batch() if sized else self.photons
        if self.max_photons < least:
            where = f" at {self.width}x{self.height}" if sized else ""
            raise SettingsError(f"max_photons = {self.max_photons}: below the {least:,} photons every render with a "
                                f"noise target draws (photons = {self.photons} over {self.batches} batches{where}), "
                                f"beyond which the cap stops the batches the target adds; give max_photons >= "
                                f"{least} or fewer photons")

    def _check_samples_per_render(self) -> None:
        """One batch is one Mitsuba render of width × height × its samples per pixel,
        which must stay within MAX_SAMPLES_PER_RENDER (2^32: Mitsuba splits a larger
        render into passes that its sampler then refuses, a RuntimeError after the first
        batch)."""
        for what, spp in (("photons", self.photon_spp_per_batch()), ("spp", self.camera_spp_per_batch())):
            samples = spp * self.pixels()
            if samples > MAX_SAMPLES_PER_RENDER:
                per_pixel = MAX_SAMPLES_PER_RENDER // self.pixels()  # a batch's samples per pixel
                most = per_pixel * self.batches * (self.pixels() if what == "photons" else 1)
                raise SettingsError(f"{what} = {getattr(self, what)}: one batch of {what} / batches at "
                                    f"{self.width}x{self.height} is {samples:,} samples, more than Mitsuba renders "
                                    f"at once (2^32); use at most {most:,} {what} over {self.batches} batches, or "
                                    f"more batches")

    def resolved(self, scene: Scene) -> "ReferenceSettings":
        """The settings with width/height filled from the scene camera (SettingsError
        when a batch is then too large to render)."""
        return replace(self, width=self.width or scene.camera.width, height=self.height or scene.camera.height)

    def to_dict(self) -> dict:
        d = asdict(self)
        if self.target_noise is not None:
            d["target_noise"] = dict(self.target_noise)
        return d

    def pixels(self) -> int:
        """width × height of resolved settings (both set)."""
        return cast(int, self.width) * cast(int, self.height)

    def photon_spp_per_batch(self) -> int:
        """Light paths per pixel of one light-tracer batch (resolved settings)."""
        return max(1, math.ceil(self.photons / self.batches / self.pixels()))

    def photons_per_batch(self) -> int:
        """Light paths of one light-tracer batch (resolved settings)."""
        return self.photon_spp_per_batch() * self.pixels()

    def photon_cap_reached(self, photons: int) -> bool:
        """Whether one more light batch after ``photons`` would pass ``max_photons``."""
        return photons + self.photons_per_batch() > self.max_photons

    def orders_spp_per_batch(self) -> int:
        """Light paths per pixel of one batch of the orders stream (max_scatter > 1)."""
        return max(1, self.photon_spp_per_batch() // ORDERS_SHARE)

    def camera_spp_per_batch(self) -> int:
        """Camera samples per pixel of one camera batch."""
        return max(1, self.spp // self.batches)

    def batch_identity(self) -> dict:
        """What one batch is (resolved settings): every field but the budget ones
        (BUDGET_FIELDS), with the sizes of one batch of each stream. Batch b of two
        renders with one identity is the same image, so a cache entry is keyed by it."""
        d = {k: v for k, v in asdict(self).items() if k not in BUDGET_FIELDS}
        orders = {"orders_spp_per_batch": self.orders_spp_per_batch()} if self.max_scatter > 1 else {}
        return {**d, "photon_spp_per_batch": self.photon_spp_per_batch(),
                "camera_spp_per_batch": self.camera_spp_per_batch(), **orders}

    def targets(self) -> dict:
        """component → target floor ({} without target_noise), for the components this
        render has (the model term's only with max_scatter > 1)."""
        return {name: floor for name, floor in self.target_noise or ()
                if self.max_scatter > 1 or not name.endswith("_ms")}


def parse_target_noise(value: float | str | Mapping[str, float | str] | Iterable[tuple[str, float | str]]) -> tuple:
    """((component, floor), ...) in NOISE_COMPONENTS order from a number (every
    component), a mapping, pairs, or text "0.005" / "caustic=0.005,fog=0.002"."""
    if isinstance(value, str):
        text = value.strip()
        if "=" not in text:
            value = _floor_value("target_noise", text)
        else:
            pairs: dict[str, float | str] = {}
            for part in text.split(","):
                name, _, number = part.partition("=")
                if name.strip() in pairs:
                    raise SettingsError(f"target_noise {text!r}: component {name.strip()!r} given twice")
                pairs[name.strip()] = number
            value = pairs
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = {name: value for name in NOISE_COMPONENTS}
    try:
        pairs = dict(cast("Mapping[str, float | str] | Iterable[tuple[str, float | str]]", value))
    except (TypeError, ValueError):  # true, a list of numbers: not a floor, a mapping or pairs
        raise SettingsError(f"target_noise = {value!r}: expected a noise floor (0.005), \"none\" or floors per "
                            f"component (caustic=0.005,fog=0.002)") from None
    for name in pairs:
        if name not in NOISE_COMPONENTS:
            raise SettingsError(f"target_noise component {name!r}: expected one of {', '.join(NOISE_COMPONENTS)}")
    if not pairs:
        raise SettingsError("target_noise: expected at least one component")
    return tuple((name, _floor_value(f"target_noise {name}", pairs[name])) for name in NOISE_COMPONENTS
                 if name in pairs)


def _floor_value(label: str, number) -> float:
    try:
        v = float(number)
    except (TypeError, ValueError):
        raise SettingsError(f"{label} = {number!r}: expected a number in (0, 1), e.g. 0.005 for 0.5%") from None
    if isinstance(number, bool) or not 0 < v < 1:
        raise SettingsError(f"{label} = {number!r}: expected a number in (0, 1), e.g. 0.005 for 0.5%")
    return v


def check_mode(mode: str) -> str:
    """``mode`` if a reference can be requested in it (:data:`REQUEST_MODES`), else
    :class:`SettingsError`."""
    if mode not in REQUEST_MODES:
        hint = " (the higher orders come with max_scatter > 1)" if mode == "orders" else ""
        raise SettingsError(f"mode = {mode!r}: expected one of {', '.join(REQUEST_MODES)}{hint}")
    return mode
