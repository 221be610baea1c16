"""The GLSL spot falloff against Mitsuba's spot emitter itself, and max_scatter."""

from __future__ import annotations

import math

import numpy as np

from tests.shared import make_scene, sphere_spec
from volcaustics.approx.glsl import build_source
from volcaustics.approx.light import spot_constants
from volcaustics.reference.mi_setup import mitsuba
from volcaustics.reference.render.export import to_mitsuba
from volcaustics.reference.render.integrators import VolumetricLightTracer, configure

mi = mitsuba()

FALLOFF_SHADER = """
#include "common/spot.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { vec4 dirs[]; };
layout(std430, binding = 1) writeonly buffer Out { float value[]; };
uniform uint count;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < count) value[i] = light_intensity.x * spot_falloff(dirs[i].xyz);
}
"""


def test_glsl_spot_matches_mitsuba_spot(ctx):
    scene = make_scene([], light_dir=(0.2, -1.0, 0.1), cutoff=30.0, beam=18.0, intensity=3.0, floor=False,
                       sigma_s=0.0)
    light = scene.light
    rng = np.random.default_rng(0)
    axis = np.asarray(light.direction)
    # directions within 35 degrees of the axis: inside the beam, the ramp, and outside
    theta = np.radians(rng.uniform(0, 35, 4096))
    phi = rng.uniform(0, 2 * np.pi, 4096)
    t1 = np.cross(axis, [0, 0, 1.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(axis, t1)
    dirs = (np.cos(theta)[:, None] * axis
            + np.sin(theta)[:, None] * (np.cos(phi)[:, None] * t1 + np.sin(phi)[:, None] * t2))
    # GLSL
    cs = ctx.compute_shader(build_source(FALLOFF_SHADER))
    for name, value in spot_constants(light).items():
        if name in cs:
            cs[name].value = value
    data = np.zeros((len(dirs), 4), np.float32)
    data[:, :3] = dirs
    src, out = ctx.buffer(data.tobytes()), ctx.buffer(reserve=4 * len(dirs))
    src.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    cs["count"].value = len(dirs)
    cs.run(group_x=(len(dirs) + 63) // 64)
    glsl = np.frombuffer(out.read(), np.float32).astype(np.float64)
    for r in (cs, src, out):
        r.release()
    # Mitsuba: the spot's contribution at unit distance along each direction
    mi_scene = mi.load_dict(to_mitsuba(scene))
    emitter = mi_scene.emitters()[0]
    it = mi.Interaction3f()
    pts = np.asarray(light.position) + dirs
    it.p = mi.Point3f(*pts.T.astype(np.float32))
    ds, value = emitter.sample_direction(it, mi.Point2f(0.5, 0.5))
    mitsuba_value = np.asarray(value.x, np.float64) * np.asarray(ds.dist, np.float64) ** 2
    # Same float32 formula and acos polynomial on both sides: what differs is the rounding
    # of the float32 query points and of Mitsuba's spot frame (~1e-7 rad of direction),
    # which the ramp (3 W/sr over 12 degrees) turns into ~2e-6 W/sr.
    err = np.abs(glsl - mitsuba_value)
    print("spot falloff: max |GLSL - Mitsuba|", err.max(), "W/sr")
    assert err.max() < 1e-5
    ramp = (theta > np.radians(18.5)) & (theta < np.radians(29.5))
    assert ramp.sum() > 500 and np.all((glsl[ramp] > 0) & (glsl[ramp] < 3.0))
    assert np.all(glsl[theta > np.radians(30.5)] == 0)


def _caustic_total(scene, max_scatter, seeds=6):
    mi_scene = mi.load_dict(to_mitsuba(scene))
    props = mi.Properties()
    props["mode"] = "caustic"
    props["max_scatter"] = max_scatter
    tracer = configure(VolumetricLightTracer(props), scene, mi_scene)
    totals = [np.asarray(mi.render(mi_scene, integrator=tracer, seed=s, spp=256))[..., :3].sum() for s in range(seeds)]
    return float(np.mean(totals)), float(np.std(totals, ddof=1) / math.sqrt(seeds))


def test_multiple_scattering_adds_light():
    """max_scatter 2 only adds non-negative paths, so it brightens the caustic beyond the
    noise; the added (second-order) part grows with sigma_s relative to the first order."""
    gains = {}
    for sigma_s in (0.1, 0.6):
        scene = make_scene([(sphere_spec(0.35, (0.0, 1.5, 0.0), 12), 1.5, (0, 0, 0))], cutoff=25.0,
                           sigma_s=sigma_s, sigma_a=0.0, width=24, height=24)
        (m1, e1), (m2, e2) = _caustic_total(scene, 1), _caustic_total(scene, 2)
        assert m2 - m1 > 3 * math.hypot(e1, e2), (sigma_s, m1, m2, e1, e2)
        gains[sigma_s] = (m2 - m1) / m1
    assert gains[0.6] > gains[0.1], gains


def test_registered_integrators_load_by_name():
    from volcaustics.reference.render.camera_integrator import SingleScatterIntegrator

    tracer = mi.load_dict({"type": "vc_lighttracer", "mode": "fog", "max_scatter": 2})
    assert isinstance(tracer, VolumetricLightTracer) and tracer.mode == "fog" and tracer.max_scatter == 2
    assert isinstance(mi.load_dict({"type": "vc_singlescatter"}), SingleScatterIntegrator)
