"""Transmittance and free flights in the medium, homogeneous or heterogeneous, in Dr.Jit.

A homogeneous medium keeps its closed forms: T = exp(−σt·d), free flights drawn at
``sigma_bar`` (the numbers the reference always made). A heterogeneous one
(σt(x) = ρ(x)·σt, ``scenes.density``) is tracked through its density grid, read as a
Dr.Jit ``Texture3f`` (trilinear, clamped, the grid's convention; 0 outside its box)
against one majorant μ = max ρ · max σt (Novák et al. 2014, "Residual ratio tracking";
Novák et al. 2018, "Monte Carlo methods for physically based volume rendering", §5):

* :meth:`TrackedMedium.transmittance`: residual ratio tracking, an unbiased estimate of
  exp(−∫σt ds) per channel: the control ρ_min·σt in closed form, times tentative
  collisions at rate μ_r = 2·(max ρ − min ρ)·max σt, each multiplying by
  1 − (σt(x) − ρ_min·σt)/μ_r (Novák et al. 2014, §4). Twice the residual's bound keeps
  every factor ≥ ½, so an estimate never collapses to 0 as a track-length estimate does
  (a grid of ones, which is its control alone, gives the closed form exactly);
* :meth:`TrackedMedium.free_flight` (heterogeneous only): delta tracking: tentative collisions at
  rate μ, each real with probability σ̄(x)/μ (σ̄ the channels' mean), with the weights
  that keep RGB σt unbiased.

Every tentative collision takes one ``sampler.next_1d()`` (two for a free flight): the
reference's own independent numbers, not the GPU's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import drjit as dr

from volcaustics.scenes.medium_grid import density_grid

from ..mi_setup import mitsuba

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

mi = mitsuba()


class TrackedMedium:
    """The scene's medium as the integrators sample it (``sigma_s``, ``sigma_t``: Color3f;
    ``sigma_bar``: float; ``heterogeneous``: whether a density grid scales them)."""

    def __init__(self, scene: Scene):
        medium = scene.medium
        self.sigma_s = mi.Color3f(*(float(x) for x in medium.sigma_s))
        self.sigma_t = mi.Color3f(*(float(x) for x in medium.sigma_t))
        self.sigma_bar = medium.sigma_bar
        grid = density_grid(scene) if medium.is_heterogeneous else None
        self.heterogeneous = grid is not None
        if grid is not None:
            self.texture = mi.Texture3f(mi.TensorXf(grid.values[..., None]), filter_mode=dr.FilterMode.Linear,
                                        wrap_mode=dr.WrapMode.Clamp)
            self.lo = mi.ScalarPoint3f(*(float(x) for x in grid.lo))
            self.extent = mi.ScalarVector3f(*(float(x) for x in grid.hi - grid.lo))
            top, self.rho_min = float(grid.values.max()), float(grid.values.min())
            self.majorant = top * max(float(x) for x in medium.sigma_t)
            self.residual_rate = 2.0 * (top - self.rho_min) * max(float(x) for x in medium.sigma_t)

    def density(self, p: Any, active: Any = True) -> Any:
        """ρ at points ``p`` (Point3f): Float, 0 outside the grid's box (1 when homogeneous)."""
        if not self.heterogeneous:
            return mi.Float(1.0)
        u = (p - self.lo) / self.extent
        inside = dr.all((u >= 0.0) & (u <= 1.0))
        return dr.select(inside, self.texture.eval(mi.Point3f(u), active & inside)[0], 0.0)

    def scattering(self, p: Any, active: Any = True) -> Any:
        """σs at ``p`` (Color3f, 1/m)."""
        return self.sigma_s * self.density(p, active) if self.heterogeneous else self.sigma_s

    def transmittance(self, origin: Any, direction: Any, length: Any, sampler: Any, active: Any = True) -> Any:
        """exp(−∫₀^length σt(origin + s·direction) ds) per channel (Color3f): exact when
        homogeneous, ratio tracking when heterogeneous (unbiased, ≥ 0)."""
        if not self.heterogeneous:
            return dr.exp(-self.sigma_t * length)
        return self.ratio_tracking(origin, direction, length, sampler, active)

    @dr.syntax
    def ratio_tracking(self, origin: Any, direction: Any, length: Any, sampler: Any, active: Any = True) -> Any:
        """Residual ratio tracking of the transmittance through the density grid (Color3f)."""
        control = self.sigma_t * self.rho_min
        tr = dr.exp(-control * length)             # the running estimate, from the control's closed form
        t = mi.Float(0.0)                           # distance tracked so far
        tracking = mi.Bool(active) & (length > 0.0) & (self.residual_rate > 0.0)
        while dr.hint(tracking, label="ratio_tracking"):
            t -= dr.log(1.0 - sampler.next_1d(tracking)) / self.residual_rate
            tracking &= t < length
            residual = self.sigma_t * self.density(origin + t * direction, tracking) - control
            tr[tracking] = tr * (1.0 - residual / self.residual_rate)
        return tr

    @dr.syntax
    def free_flight(self, origin: Any, direction: Any, length: Any, sampler: Any,
                    active: Any = True) -> tuple[Any, Any, Any]:
        """A free flight along origin + s·direction, s < ``length``, in a heterogeneous medium:
        (s, whether it scattered there, the weight of the outcome, Color3f). Delta tracking
        against the majorant on the grey σ̄(x) = ρ(x)·sigma_bar, weighted for RGB σt as the
        homogeneous tracer is (``integrators``): a real collision by σs(x)/σ̄(x), each null
        one by (1 − σt(x)/μ)/(1 − σ̄(x)/μ), so the weight's mean is T_rgb/T̄ (Kutz et al.
        2017, "Spectral and decomposition tracking", §4)."""
        weight = mi.Color3f(1.0)                    # ratio of the channels' to the grey tracking's
        s = mi.Float(0.0)                           # distance tracked so far
        scattered = mi.Bool(False)                  # a real collision was found
        tracking = mi.Bool(active) & (length > 0.0) & (self.majorant > 0.0)
        while dr.hint(tracking, label="delta_tracking"):
            s -= dr.log(1.0 - sampler.next_1d(tracking)) / self.majorant
            tracking &= s < length
            rho = self.density(origin + s * direction, tracking)
            grey = rho * self.sigma_bar / self.majorant          # probability that it is real
            real = tracking & (sampler.next_1d(tracking) < grey)
            weight[real] = weight * rho * self.sigma_s / (rho * self.sigma_bar)
            weight[tracking & ~real] = weight * dr.maximum(1.0 - rho * self.sigma_t / self.majorant, 0.0) / (1.0 - grey)
            scattered |= real
            tracking &= ~real
        return dr.select(scattered, s, length), scattered & active, weight
