// The beam × camera-ray estimate with a 1-D kernel (Jarosz, Nowrouzezahrai, Sadeghi &
// Jensen 2011, "A comprehensive theory of volumetric radiance estimation using photon
// points and beams", the "Beam × Beam (1D)" estimator): for the pixel ray x(t) = eye + t·ω
// and the beam y(s) = start + s·d of power Φ, at their closest approach (t, s, distance u)
//   L = Φ · σs · p(d, −ω) · exp(−σt·s) · exp(−σt·t) · k(u) / sin θ,
// θ the angle between ω and d (1/sin θ: the Jacobian from the kernel's line across the
// beam to the beam's length), k a 1-D Gaussian of σ cut at TRUNCATION·σ and divided by
// the mass it keeps. The beam's ends are not cut sharp but as the paper's 3D Gaussians
// end: a row of them along [0, length], seen along the pixel ray, sums to exactly
//   k(u)/sin θ · ½[erf((length − s)·sin θ/(√2σ)) + erf(s·sin θ/(√2σ))]
// (a point of the beam at s' lies (s' − s)·sin θ off the ray in the plane of both), so
// a beam is the limit of dense point splats, and its ends, which an oblique beam crosses
// in a few pixels, do not alias (a sharp cut lost or gained 2% of a beam at sin θ = 0.3
// and 160 pixels). Only closest approaches in front of the camera and before its first
// surface (the G-buffer) count; the transmittances are taken at the closest approach
// within [0, length]. Point-sampled at the pixel centre, as the paper's splats.
// Controls (negative controls of tests): BEAM_NO_SINE drops 1/sin θ,
// BEAM_NO_CAMERA_TRANSMITTANCE drops exp(−σt·t).
#include "common/erf.glsl"
#include "common/phase.glsl"
#include "splat/kernel.glsl"
#include "common/kinds.glsl"

uniform vec3 eye;
uniform vec3 sigma_s;
uniform vec3 sigma_t;
uniform sampler2D scene_distance;  // G-buffer (distance to the first surface, KIND_*, material, 0)

in vec3 v_corner;
flat in vec3 v_start;
flat in vec3 v_dir;
flat in float v_length;
flat in float v_sigma;
flat in vec3 v_power;

out vec4 out_color;

void main() {
    vec3 ray = normalize(v_corner - eye);
    vec3 w0 = eye - v_start;
    float b = dot(ray, v_dir);
    float sin2 = 1.0 - b * b;
    if (sin2 < 1e-8) discard;  // along the beam: a set of rays of measure zero
    float d_ray = dot(ray, w0), d_beam = dot(v_dir, w0);
    float t = (b * d_beam - d_ray) / sin2;  // closest approach along the pixel ray (m from the eye)
    float s = (d_beam - b * d_ray) / sin2;  // ... along the beam (m from its start)
    float sin_theta = sqrt(sin2);
    float reach = TRUNCATION * v_sigma / sin_theta;  // the ends' Gaussians, cut as the kernel
    if (s < -reach || s > v_length + reach || t <= 0.0) discard;
    vec4 g = texelFetch(scene_distance, ivec2(gl_FragCoord.xy), 0);
    if (gbuffer_kind(g) != KIND_NONE && t > g.x) discard;
    vec3 gap = w0 + t * ray - s * v_dir;
    float u2 = dot(gap, gap);
    float R = TRUNCATION * v_sigma;
    if (u2 > R * R) discard;
    float k = exp(-u2 / (2.0 * v_sigma * v_sigma)) / (2.5066282746310002 * v_sigma * AXIS_KEPT_MASS);
    float along = sin_theta * 0.7071067811865476 / v_sigma;
    float ends = 0.5 * (erf_approx((v_length - s) * along) + erf_approx(s * along));
#ifdef BEAM_NO_SINE
    float jacobian = 1.0;
#else
    float jacobian = 1.0 / sin_theta;
#endif
    // the transmittance along the beam and from there to the eye, at the closest approach
    // within the beam (past its ends, where its Gaussians still reach, at the end itself)
    float on_beam = clamp(s, 0.0, v_length);
#ifdef BEAM_NO_CAMERA_TRANSMITTANCE
    vec3 transmittance = exp(-sigma_t * on_beam);
#else
    vec3 transmittance = exp(-sigma_t * (on_beam + distance(v_start + on_beam * v_dir, eye)));
#endif
    out_color = vec4(v_power * sigma_s * phase_eval(-b) * transmittance * k * ends * jacobian, 1.0);
}
