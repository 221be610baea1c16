"""The camera integrator of the ground truth, written with Dr.Jit on Mitsuba's scene queries.

* ``vc_singlescatter`` (:class:`SingleScatterIntegrator`): camera rays to the first
  surface; the fog integral of direct (unrefracted) spot light with shadows of all
  objects by one equiangular sample toward the light on the part of the ray inside
  the spot's cone; direct Lambert light on
  diffuse surfaces; ``mask_specular`` where the ray hits glass. Its AOVs are
  ``fog.R/G/B``, ``direct.R/G/B``, ``mask.Y``.

It is configured after construction with ``integrators.configure`` (scene model, Mitsuba
scene), as the light tracer is.
"""

from __future__ import annotations

from typing import Any

import drjit as dr

from volcaustics.scenes.formats import KIND_DIFFUSE, KIND_SPECULAR

from ..mi_setup import mitsuba
from .sampling import cone_interval, equiangular, hg_phase

mi = mitsuba()


class SingleScatterIntegrator(mi.SamplingIntegrator):  # type: ignore[name-defined]
    """Fog, direct and mask_specular from the camera; see the module docstring."""

    def __init__(self, props=mi.Properties()):
        mi.SamplingIntegrator.__init__(self, props)

    def aov_names(self) -> list[str]:
        return ["fog.R", "fog.G", "fog.B", "direct.R", "direct.G", "direct.B", "mask.Y"]

    @dr.syntax
    def sample(self, scene: Any, sampler: Any, ray: Any, medium: Any = None,
               active: Any = True) -> tuple[Any, Any, list[Any]]:
        ray = mi.Ray3f(ray)
        si = scene.ray_intersect(ray, active)
        hit = active & si.is_valid()
        kind, index, absorption = self.table.lookup(mi, si, hit)
        fog = mi.Color3f(0.0)
        if self.has_medium:
            length = dr.select(hit, si.t, 0.0)
            light_pos = scene.emitters()[0].world_transform().translation()
            # only the part inside the spot's cone receives light: sample it alone
            s_in, s_out, use = cone_interval(ray.o, ray.d, length, light_pos, self.light_axis, self.cos_cutoff)
            use &= hit
            t, pdf = equiangular(ray.o + s_in * ray.d, ray.d, s_out - s_in, light_pos, sampler.next_1d(use))
            t += s_in
            it = dr.zeros(mi.Interaction3f)
            it.p = ray(t)
            it.time = ray.time
            it.wavelengths = ray.wavelengths
            ds, emitted = scene.sample_emitter_direction(it, sampler.next_2d(use), True, use)  # shadow ray included
            use &= ds.pdf > 0.0
            sigma_s = mi.Color3f(self.sigma_s)
            if dr.hint(self.medium.heterogeneous, mode="scalar"):  # from the eye to t, and on to the light
                tr = (self.medium.transmittance(ray.o, ray.d, t, sampler, use)
                      * self.medium.transmittance(it.p, ds.d, ds.dist, sampler, use))
                sigma_s = self.medium.scattering(it.p, use)
            else:
                tr = dr.exp(-self.sigma_t * (t + ds.dist))
            phase = hg_phase(dr.dot(-ds.d, -ray.d), self.g)  # light travels −ds.d, leaves towards the camera (−ray.d)
            fog[use] = sigma_s * phase * emitted * tr / pdf

        direct = mi.Color3f(0.0)
        on_diffuse = hit & (kind == KIND_DIFFUSE)
        ds, emitted = scene.sample_emitter_direction(si, sampler.next_2d(on_diffuse), True, on_diffuse)
        ctx = mi.BSDFContext()
        bsdf_value = si.bsdf().eval(ctx, si, si.to_local(ds.d), on_diffuse)
        if dr.hint(self.has_medium and self.medium.heterogeneous, mode="scalar"):
            lit = on_diffuse & (ds.pdf > 0.0)
            emitted *= (self.medium.transmittance(ray.o, ray.d, si.t, sampler, lit)
                        * self.medium.transmittance(si.p, ds.d, ds.dist, sampler, lit))
        elif self.has_medium:
            emitted *= dr.exp(-self.sigma_t * (si.t + ds.dist))
        direct[on_diffuse & (ds.pdf > 0.0)] = bsdf_value * emitted

        mask = dr.select(hit & (kind == KIND_SPECULAR), 1.0, 0.0)
        total = fog + direct
        return total, active, [fog.x, fog.y, fog.z, direct.x, direct.y, direct.z, mask]

    def to_string(self) -> str:
        return "SingleScatterIntegrator[]"


mi.register_integrator("vc_singlescatter", lambda props: SingleScatterIntegrator(props))
