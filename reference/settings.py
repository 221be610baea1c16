"""Settings of a reference render (names as on the CLI)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace


MODES = ("caustic", "fog", "all", "surface")  # which light paths the light tracer counts (reference.integrators)


class SettingsError(ValueError):
    """A reference setting is out of range; the message names it and what is allowed."""


@dataclass(frozen=True)
class ReferenceSettings:
    """photons: light paths of the caustic light tracer, over all batches.
    spp: camera samples per pixel of the fog/direct integrator, over all batches.
    batches: independent batches (seeds seed·B + b) for the per-pixel variance.
    max_scatter: 1 = single scattering (the paper's model); more for multiple scattering.
    width, height: None takes the scene camera's."""

    photons: int = 1 << 24
    spp: int = 256
    batches: int = 8
    max_scatter: int = 1
    width: int | None = None
    height: int | None = None
    seed: int = 0

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

    def resolved(self, scene) -> "ReferenceSettings":
        return replace(self, width=self.width or scene.camera.width, height=self.height or scene.camera.height)

    def to_dict(self) -> dict:
        return asdict(self)


def check_mode(mode: str) -> str:
    """``mode`` if it is one of :data:`MODES`, else :class:`SettingsError`."""
    if mode not in MODES:
        raise SettingsError(f"mode = {mode!r}: expected one of {', '.join(MODES)}")
    return mode
