"""common/optics.glsl against closed forms: Snell's law, Fresnel equations (sine/tangent
form, an independent formula), total internal reflection."""

from __future__ import annotations

import numpy as np

from volcaustics.approx.glsl import build_source

SHADER = """
#include "common/optics.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { vec4 cases[]; };   // (cos_i, eta, 0, 0)
layout(std430, binding = 1) writeonly buffer Out { vec4 result[]; }; // (R, refracted x, y, ok)
uniform uint count;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    float cos_i = cases[i].x, eta = cases[i].y;
    vec3 d = vec3(sqrt(1.0 - cos_i * cos_i), -cos_i, 0.0);  // incident, normal +y
    vec3 t;
    bool ok = refract_dir(d, vec3(0.0, 1.0, 0.0), eta, t);
    result[i] = vec4(fresnel_dielectric(cos_i, eta), t.x, t.y, ok ? 1.0 : 0.0);
}
"""


def run(ctx, cos_i, eta):
    cases = np.zeros((len(cos_i), 4), np.float32)
    cases[:, 0], cases[:, 1] = cos_i, eta
    cs = ctx.compute_shader(build_source(SHADER))
    src, out = ctx.buffer(cases.tobytes()), ctx.buffer(reserve=cases.nbytes)
    src.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    cs["count"].value = len(cases)
    cs.run(group_x=(len(cases) + 63) // 64)
    res = np.frombuffer(out.read(), np.float32).reshape(-1, 4).astype(np.float64)
    for r in (cs, src, out):
        r.release()
    return res


def test_snell_and_fresnel_entering_glass(ctx):
    theta_i = np.linspace(0.01, np.pi / 2 - 0.01, 200)
    eta = 1.5
    res = run(ctx, np.cos(theta_i), eta)
    theta_t = np.arcsin(np.sin(theta_i) / eta)
    # Snell: sin(theta_t) = sin(theta_i) / eta, transmitted direction below the surface
    assert np.allclose(res[:, 1], np.sin(theta_t), atol=2e-6)
    assert np.allclose(res[:, 2], -np.cos(theta_t), atol=2e-6) and np.all(res[:, 3] == 1)
    rs = (np.sin(theta_i - theta_t) / np.sin(theta_i + theta_t)) ** 2
    rp = (np.tan(theta_i - theta_t) / np.tan(theta_i + theta_t)) ** 2
    assert np.allclose(res[:, 0], 0.5 * (rs + rp), atol=2e-6)


def test_normal_incidence_and_brewster(ctx):
    res = run(ctx, np.array([1.0, np.cos(np.arctan(1.5))]), 1.5)
    assert abs(res[0, 0] - ((1.5 - 1) / (1.5 + 1)) ** 2) < 1e-6  # ((n-1)/(n+1))^2 = 0.04
    rs_brewster = (np.sin(np.arctan(1.5) - np.arctan(1 / 1.5)) / np.sin(np.pi / 2)) ** 2
    assert abs(res[1, 0] - 0.5 * rs_brewster) < 1e-6  # R_p vanishes at Brewster's angle


def test_total_internal_reflection(ctx):
    eta = 1 / 1.5  # leaving glass
    critical = np.arcsin(eta)
    theta = np.array([critical - 0.02, critical + 0.02, 1.2])
    res = run(ctx, np.cos(theta), eta)
    assert res[0, 3] == 1 and res[0, 0] < 1
    assert np.all(res[1:, 3] == 0) and np.all(res[1:, 0] == 1)
    # reciprocity: same R from both sides for corresponding angles (Stokes relations)
    inside = np.array([0.3, 0.5])
    outside = np.arcsin(np.sin(inside) / eta)
    a, b = run(ctx, np.cos(inside), eta)[:, 0], run(ctx, np.cos(outside), 1 / eta)[:, 0]
    assert np.allclose(a, b, atol=2e-6)
