"""Parameters of the approximation, named as everywhere (DESIGN.md): CLI, tables, sweeps."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace


class ParamError(ValueError):
    """A parameter value is out of range; the message names it and what is allowed."""


@dataclass(frozen=True)
class ApproxParams:
    """Paper defaults (Wang, Wang & Chen): photon_res 1500, layers 4, steps 4,
    iterations 30, peak_samples 8; width/height None take the scene camera's.

    photon_res      photon map resolution (photons = covered texels of photon_res²)
    layers          light-map levels; each level is a front-face and a back-face map
    layer_strategy  "threshold" (paper §4.2) or "peel" (depth peeling per facing)
    iterations      binary-search iterations per detected crossing
    peak_samples    interior samples per segment and map to find the first sign change
    steps           interaction steps (photon maps) traced
    splat_radius    standard deviation of the splatted 3D Gaussian (m)
    light_res       resolution of the light layer maps and shadow map
    width, height   image size (pixels)
    fog_steps       ray-marching samples of the fog integral per pixel
    fresnel         "deterministic" (refracted power × (1 − R)) or "stochastic" (choose by R)
    seed            seed of the shared RNG
    """

    photon_res: int = 1500
    layers: int = 4
    layer_strategy: str = "threshold"
    iterations: int = 30
    peak_samples: int = 8
    steps: int = 4
    splat_radius: float = 0.01
    light_res: int = 1024
    width: int | None = None
    height: int | None = None
    fog_steps: int = 64
    fresnel: str = "deterministic"
    seed: int = 0

    def __post_init__(self):
        ranges = {"photon_res": (1, 8192), "layers": (1, 8), "iterations": (0, 64), "peak_samples": (0, 256),
                  "steps": (1, 32), "light_res": (16, 8192), "fog_steps": (1, 4096), "seed": (0, 2**32 - 1)}
        for name, (lo, hi) in ranges.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
                raise ParamError(f"{name} = {value!r}: expected an integer in [{lo}, {hi}]")
        for name in ("width", "height"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 16384):
                raise ParamError(f"{name} = {value!r}: expected an integer in [1, 16384] (or unset: the scene's)")
        if not isinstance(self.splat_radius, (int, float)) or not 0 < self.splat_radius < 10:
            raise ParamError(f"splat_radius = {self.splat_radius!r}: expected a number in (0, 10) metres")
        if self.layer_strategy not in ("threshold", "peel"):
            raise ParamError(f'layer_strategy = {self.layer_strategy!r}: expected "threshold" or "peel"')
        if self.fresnel not in ("deterministic", "stochastic"):
            raise ParamError(f'fresnel = {self.fresnel!r}: expected "deterministic" or "stochastic"')

    def resolved(self, scene) -> "ApproxParams":
        """The parameters with width/height filled from the scene camera."""
        return replace(self, width=self.width or scene.camera.width, height=self.height or scene.camera.height)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in fields(cls)]


QUICK = ApproxParams(photon_res=256, light_res=256, width=256, height=256, fog_steps=48, splat_radius=0.02)
PAPER = ApproxParams(width=800, height=800)
