"""Mitsuba integrators of the ground truth, written with Dr.Jit on Mitsuba's scene queries.

* ``vc_lighttracer`` (:class:`VolumetricLightTracer`): photons from the spot light,
  specular chains through dielectrics (Mitsuba's dielectric BSDF samples reflection
  or refraction by Fresnel, importance transport), Beer–Lambert inside glass; every
  medium segment is clipped to the view pyramid and n vertices on it, stratified
  equiangularly toward the camera (Kulla & Fajardo 2012), are connected to the sensor
  (``sensor.sample_direction``, shadow ray: glass blocks it, transmittance, phase)
  and splatted with weight 1/n. n grows with the segment's geometric term seen from
  the eye, ∫ dt/d² = Δθ/D, up to one connection per pixel of its image: a beam that
  passes close to the camera is drawn along its streak instead of splatting all its
  Δθ/D into one pixel (the fireflies before stratified connections). ``mode`` chooses which
  paths count: ``caustic`` (≥1 specular interaction before the scattering vertex,
  docs/conventions.md), ``fog`` (none), ``all``, or ``surface`` (no medium: the first diffuse
  vertex is connected instead, to check against Mitsuba's ``ptracer``).
  ``max_scatter`` > 1 continues paths through real scattering events (analog free
  flight, phase sampling) to measure what single scattering leaves out.
It and ``camera_integrator.SingleScatterIntegrator`` are configured after construction
with :func:`configure` (scene model, Mitsuba scene): the medium (``tracking.TrackedMedium``:
coefficients, and a heterogeneous medium's density grid) and the shape table.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, TypeVar

import drjit as dr

from volcaustics.scenes.formats import KIND_DIFFUSE, KIND_SPECULAR, PATH_INTERACTIONS

from ..mi_setup import mitsuba
from ..settings import MODES
from .orders import ORDER_COMPONENTS, SINGLE_ORDER
from .sampling import (
    GEOMETRY_PER_CONNECTION,
    ViewPyramid,
    equiangular,
    hg_phase,
    hg_sample,
    subtended_angle,
)
from .shapes import ShapeTable
from .tracking import TrackedMedium

if TYPE_CHECKING:
    import numpy as np

    from volcaustics.scenes.model import Scene

mi = mitsuba()
# configure() returns the integrator it was given
_Integrator = TypeVar("_Integrator", bound=Any)

def configure(integrator: _Integrator, scene_model: Scene, mi_scene: Any) -> _Integrator:
    """Give an integrator of this module the scene's medium and shape table."""
    medium = scene_model.medium
    integrator.sigma_s = mi.Color3f(*(float(x) for x in medium.sigma_s))
    integrator.sigma_t = mi.Color3f(*(float(x) for x in medium.sigma_t))
    integrator.sigma_bar = medium.sigma_bar
    integrator.has_medium = not medium.is_vacuum
    integrator.medium = TrackedMedium(scene_model)
    integrator.g = float(medium.phase.g) if medium.phase.kind == "hg" else 0.0
    integrator.table = ShapeTable(mi, mi_scene, scene_model)
    light = scene_model.light
    integrator.light_axis = mi.Vector3f(*(float(x) for x in light.direction))
    integrator.cos_cutoff = math.cos(math.radians(light.cutoff_angle))
    return integrator


class VolumetricLightTracer(mi.AdjointIntegrator):  # type: ignore[name-defined]
    """The caustic (and check) light tracer; see the module docstring.

    Properties: ``mode`` (settings.MODES, default ``caustic``), ``max_scatter`` (real
    scattering events a path may continue through, default 1), ``max_path`` (segments
    traced, default ``scenes.formats.PATH_INTERACTIONS``) and ``geometry_per_connection`` (1/m, default
    :data:`GEOMETRY_PER_CONNECTION`): the most of a medium segment's geometric term
    ∫ dt / |x(t) − eye|² = Δθ / D (the angle it subtends at the eye over its line's
    distance to the eye) that one camera connection carries. A segment is clipped to
    the view pyramid and gets n = ⌈Δθ / (D · geometry_per_connection)⌉ connections,
    stratified in θ, at most one per pixel its image crosses (and never more than the film's
    width + height); each is weighted 1/n. ``beyond_model`` (mode ``orders``): count only
    the orders beyond the paper's model (``orders.SINGLE_ORDER``), which a reference's
    other streams render.
    The sensor must be a pinhole camera (``perspective``).
    """

    def __init__(self, props=mi.Properties()):
        mi.AdjointIntegrator.__init__(self, props)
        self.mode = props.get("mode", "caustic")
        self.max_scatter = int(props.get("max_scatter", 1))
        self.max_path = int(props.get("max_path", PATH_INTERACTIONS))
        self.beyond_model = bool(props.get("beyond_model", False))
        self.geometry_per_connection = float(props.get("geometry_per_connection", GEOMETRY_PER_CONNECTION))
        if self.mode not in MODES:
            raise ValueError(f"mode {self.mode!r}: expected one of {MODES}")
        if not self.geometry_per_connection > 0.0:
            raise ValueError(f"geometry_per_connection {self.geometry_per_connection!r}: expected > 0 (1/m)")

    def connections(self, view: ViewPyramid, ray: Any, t_end: Any) -> tuple[Any, Any, Any, Any]:
        """The camera connections of the medium segment ray(t), t in [0, t_end]: the part
        [s_in, s_out] the eye sees (``view``: :class:`ViewPyramid`), whether there is one,
        and how many stratified connections it gets (≥ 1): one per
        ``geometry_per_connection`` of its geometric term Δθ / D, at most one per pixel."""
        s_in, s_out, seen = view.clip(ray.o, ray.d, t_end)
        angle, dist = subtended_angle(ray(s_in), ray.d, s_out - s_in, view.eye)
        n = dr.minimum(angle / (dist * self.geometry_per_connection), angle / view.pixel_angle)
        n = dr.minimum(n, view.pixels)  # also where a degenerate segment gave inf or NaN
        return s_in, s_out, seen, mi.UInt32(dr.maximum(dr.ceil(n), 1.0))

    def prepare_orders(self, width: int, height: int) -> None:
        """Before a render in mode ``orders``: a cleared block that holds one W×H image per
        (component, order) (:data:`ORDER_COMPONENTS` × 0…max_scatter), stacked in rows."""
        self.order_size = (width, height)
        rows = height * len(ORDER_COMPONENTS) * (self.max_scatter + 1)
        self.order_block = mi.ImageBlock([width, rows], [0, 0], 3, mi.load_dict({"type": "box"}))
        self.order_block.clear()

    def order_images(self) -> np.ndarray:
        """The images of the last render in mode ``orders`` as an array
        [component, order, H, W, 3] (float64; order 0 is empty but for ``direct``)."""
        import numpy as np

        width, height = self.order_size
        image = np.asarray(self.order_block.tensor(), np.float64)
        return image.reshape(len(ORDER_COMPONENTS), self.max_scatter + 1, height, width, 3)

    def _put_order(self, uv, value, component: int, order, active):
        """Splat ``value`` at film position ``uv`` into the image of (``component``, ``order``)."""
        width, height = self.order_size
        row = mi.Float((component * (self.max_scatter + 1) + order) * height)
        self.order_block.put(mi.Point2f(uv.x, uv.y + row), [value.x, value.y, value.z], active)

    def _counts(self, specular):
        if self.mode == "caustic":
            return specular >= 1
        if self.mode == "fog":
            return specular == 0
        return dr.full(mi.Bool, True, dr.width(specular))

    @dr.syntax
    def sample(self, scene: Any, sensor: Any, sampler: Any, block: Any, sample_scale: Any) -> None:
        table = self.table
        view = ViewPyramid(sensor)
        volume = self.mode != "surface" and self.has_medium
        orders = self.mode == "orders"
        if orders and not hasattr(self, "order_block"):
            raise RuntimeError("vc_lighttracer in mode 'orders': call prepare_orders(width, height) before rendering")
        # the most real scattering events a path goes on through: in mode orders, direct
        # light may have scattered max_scatter times; else a path scatters only while a
        # later connection can still count it
        most_scatters = self.max_scatter if orders else self.max_scatter - 1

        # --- emission
        ray, throughput, emitter = scene.sample_emitter_ray(0.0, sampler.next_1d(), sampler.next_2d(),
                                                            sampler.next_2d(), True)

        # --- loop state
        active = mi.Bool(True)             # path alive
        inside = mi.Int32(-1)              # specular object the ray travels in, -1 in the medium
        absorption = mi.Color3f(0.0)       # Beer–Lambert coefficient of that object
        specular = mi.UInt32(0)            # specular interactions so far
        scatters = mi.UInt32(0)            # real scattering events so far (max_scatter > 1)
        depth = mi.UInt32(0)               # segments traced

        while dr.hint(active, label="vc_lighttracer"):
            si = scene.ray_intersect(ray, active)
            hit = active & si.is_valid()
            kind, index, absorption_at_hit = table.lookup(mi, si, hit)
            t_end = dr.select(hit, si.t, 0.0)
            in_medium = hit & (inside < 0)

            # --- camera connections along the medium segment (single scattering from this beam):
            # n vertices on the part the eye sees, stratified in the angle they subtend at the eye
            # (equiangular), so that the beam's image is drawn along its length, not in one pixel
            if volume:
                connect = in_medium & self._counts(specular) & (scatters < self.max_scatter)
                if orders and self.beyond_model:
                    connect &= scatters >= SINGLE_ORDER["fog"]  # the medium vertex is order ≥ 2
                s_in, s_out, seen, n = self.connections(view, ray, t_end)
                connect &= seen
                i = mi.UInt32(0)           # connections made on this segment
                while dr.hint(connect & (i < n), label="vc_lighttracer_connections"):
                    t, pdf = equiangular(ray(s_in), ray.d, s_out - s_in, view.eye,
                                         (mi.Float(i) + sampler.next_1d()) / mi.Float(n))
                    t += s_in
                    it = dr.zeros(mi.Interaction3f)
                    it.p = ray(t)
                    it.time = ray.time
                    it.wavelengths = ray.wavelengths
                    ds, sensor_weight = sensor.sample_direction(it, sampler.next_2d())
                    visible = (ds.pdf > 0.0) & ~scene.ray_test(it.spawn_ray_to(ds.p), ds.pdf > 0.0)
                    # from the segment's start to t, and on to the eye
                    if dr.hint(self.medium.heterogeneous, mode="scalar"):
                        tr = (self.medium.transmittance(ray.o, ray.d, t, sampler, visible)
                              * self.medium.transmittance(it.p, ds.d, ds.dist, sampler, visible))
                        sigma_s = self.medium.scattering(it.p, visible)
                    else:
                        tr = dr.exp(-self.sigma_t * (t + ds.dist))
                        sigma_s = self.sigma_s
                    value = (throughput * sigma_s * hg_phase(dr.dot(ray.d, ds.d), self.g) * tr
                             / (pdf * mi.Float(n)) * sensor_weight * sample_scale)
                    block.put(ds.uv + block.offset(), ray.wavelengths, value, 0.0, 0.0, visible)
                    if orders:
                        component = dr.select(specular >= 1, ORDER_COMPONENTS.index("caustic"),
                                              ORDER_COMPONENTS.index("fog"))
                        for c in (ORDER_COMPONENTS.index("caustic"), ORDER_COMPONENTS.index("fog")):
                            self._put_order(ds.uv, value, c, scatters + 1,
                                            visible & (component == c))
                    i += 1

            # --- free flight: attenuate to the surface, or scatter (max_scatter > 1)
            reach_surface = mi.Bool(hit)
            if volume:
                can_scatter = in_medium & (scatters < most_scatters)
                single = in_medium & ~can_scatter
                # delta tracking; ratio tracking where it only passes
                if dr.hint(self.medium.heterogeneous, mode="scalar"):
                    t_ff, scatter, w_flight = self.medium.free_flight(ray.o, ray.d, t_end, sampler, can_scatter)
                    throughput[single] *= self.medium.transmittance(ray.o, ray.d, t_end, sampler, single)
                    throughput[can_scatter] *= w_flight
                else:
                    t_ff = -dr.log(1.0 - sampler.next_1d(in_medium)) / self.sigma_bar
                    scatter = can_scatter & (t_ff < t_end)
                    # analog tracking, weighted for RGB sigma_t sampled with the mean sigma_bar
                    w_scatter = (dr.exp(-self.sigma_t * t_ff) * self.sigma_s
                                 / (self.sigma_bar * dr.exp(-self.sigma_bar * t_ff)))
                    w_pass = dr.exp(-self.sigma_t * t_end) / dr.exp(-self.sigma_bar * t_end)
                    throughput[single] *= dr.exp(-self.sigma_t * t_end)
                    throughput[can_scatter & ~scatter] *= w_pass
                    throughput[scatter] *= w_scatter
                new_dir = hg_sample(ray.d, self.g, sampler.next_2d(scatter))
                ray = dr.select(scatter, mi.Ray3f(ray(t_ff), new_dir, ray.time, ray.wavelengths), ray)
                scatters[scatter] += 1
                reach_surface &= ~scatter

            # --- surfaces
            throughput[reach_surface & (inside >= 0)] *= dr.exp(-absorption * t_end)  # Beer–Lambert in glass
            on_specular = reach_surface & (kind == KIND_SPECULAR)
            on_diffuse = reach_surface & (kind == KIND_DIFFUSE)

            if self.mode == "surface" or orders:
                lit = on_diffuse & (specular == 0) if orders else on_diffuse  # a surface caustic is outside both
                if orders and self.beyond_model:
                    lit &= scatters > SINGLE_ORDER["direct"]
                ds, sensor_weight = sensor.sample_direction(si, sampler.next_2d(lit), lit)
                seen = lit & (ds.pdf > 0.0)
                seen &= ~scene.ray_test(si.spawn_ray_to(ds.p), seen)
                ctx = mi.BSDFContext(mi.TransportMode.Importance)
                local_d = si.to_local(ds.d)
                bsdf_value = si.bsdf().eval(ctx, si, local_d, seen)
                # adjoint BSDF with shading normals (Veach 1997, §5.3): cosine ratio, no light leaks
                wi_geo = dr.dot(si.n, si.to_world(si.wi))
                wo_geo = dr.dot(si.n, ds.d)
                cos_wi, cos_wo = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(local_d)
                consistent = (wi_geo * cos_wi > 0.0) & (wo_geo * cos_wo > 0.0)
                correction = dr.select(consistent, dr.abs(cos_wi * wo_geo / (cos_wo * wi_geo)), 0.0)
                value = throughput * bsdf_value * correction * sensor_weight * sample_scale
                if dr.hint(volume and self.medium.heterogeneous, mode="scalar"):  # the medium between surface and eye
                    value *= self.medium.transmittance(si.p, ds.d, ds.dist, sampler, seen)
                elif volume:
                    value *= dr.exp(-self.sigma_t * ds.dist)
                block.put(ds.uv + block.offset(), ray.wavelengths, value, 0.0, 0.0, seen)
                if orders:
                    self._put_order(ds.uv, value, ORDER_COMPONENTS.index("direct"), scatters, seen)

            ctx = mi.BSDFContext(mi.TransportMode.Importance)
            bs, bsdf_weight = si.bsdf().sample(ctx, si, sampler.next_1d(on_specular), sampler.next_2d(on_specular),
                                               on_specular)
            wo = si.to_world(bs.wo)
            throughput[on_specular] *= bsdf_weight
            enters = dr.dot(wo, si.n) < 0.0  # outward meshes: below the geometric normal is inside
            inside[on_specular] = dr.select(enters, index, -1)
            absorption[on_specular] = dr.select(enters, absorption_at_hit, 0.0)
            specular[on_specular] += 1
            ray = dr.select(on_specular, si.spawn_ray(wo), ray)

            # --- termination: diffuse surfaces end the path (single scattering model),
            # as do misses, leaving the medium box and long specular chains
            depth += 1
            active &= (on_specular | (hit & ~reach_surface)) & (depth < self.max_path)
            active &= dr.any(throughput > 0.0)

    def aov_names(self) -> list[str]:
        return []

    def to_string(self) -> str:
        return f"VolumetricLightTracer[mode={self.mode}, max_scatter={self.max_scatter}]"


mi.register_integrator("vc_lighttracer", lambda props: VolumetricLightTracer(props))
