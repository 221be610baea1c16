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
// within [0, length]. Point-sampled at the pixel centre, as the paper's splats; a beam
// that carries its own σ (Beam.dir.w > 0: the decomposition's small kernel) has its
// kernel integrated over the pixel's area instead (beam_pixel_mass), so that a kernel
// narrower than a pixel keeps its integral whatever its offset from the pixel centres.
// A kernel whose σ changes along the beam (beam_width = differential) is taken at the
// closest approach: the 1-D kernel keeps its integral across the beam at every s, so the
// beam keeps its energy; only its ends' Gaussians take the σ of the nearer end.
// BEAM_PILOT (beam_width = balanced, approx.splat.Splatter.balance_map): the same estimate
// at the pilot's coarser pixels, written as what the balance needs per pixel: the
// luminance Y of each half of the beams (alternate rows: two interleaved estimates, whose
// difference is the frame's own noise, stratified or not) and the sum of Y·σ² (σ the
// kernel in pilot pixels at the closest approach).
// HETEROGENEOUS (a density grid): σs(x) = ρ(x)·σs at the closest approach, the transmittance
// along the beam from march_steps midpoint samples of ρ and to the eye from the camera's
// transmittance volume (common/volumes.glsl) at the closest approach; the decomposition's
// controls EXACT_MARCH and EXACT_EYE make either exact (common/density.glsl's exact_depth).
// EXACT_EYE takes the depth along the pixel's ray up to the closest approach's depth on it,
// the estimator's own (Jarosz et al. 2011 take the query ray's transmittance at its t), from
// knots along every pixel's ray (splat/eye_knots.glsl). The point's own line to the eye lies
// off the ray by less than the kernel's reach: on smoke's small-kernel beams the two differ
// by 2e-5 of the caustic (docs/decisions.md "Heterogeneous media").
// Controls (negative controls of tests): BEAM_NO_SINE drops 1/sin θ,
// BEAM_NO_CAMERA_TRANSMITTANCE drops exp(−σt·t), BEAM_CLOSEST_DEPTH depth-tests the
// closest approach alone instead of cutting the beam at the surface.
#include "common/erf.glsl"
#include "common/phase.glsl"
#include "splat/kernel.glsl"
#include "splat/beam_width.glsl"
#include "splat/pixel_ray.glsl"
#include "common/kinds.glsl"
#ifdef HETEROGENEOUS  // σs(x) = ρ(x)·σs; along the beam a fixed march, to the eye the camera's volume
#include "common/density.glsl"
#include "common/volumes.glsl"
uniform int march_steps;
#ifdef EXACT_MARCH
#include "splat/beam_knots.glsl"
flat in float v_knots[BEAM_KNOTS];  // the exact depth at the beam's knots (beam.vert.glsl)
#endif
#ifdef EXACT_EYE
#include "splat/eye_knots.glsl"
layout(std430, binding = EYE_KNOTS_BINDING) readonly buffer EyeKnots { float eye_knots[]; };  // eye_knots.comp.glsl
#endif
#endif

uniform mat4 view_proj;
uniform vec2 viewport;             // image size (pixels)
uniform vec3 eye;
uniform vec3 sigma_s;
uniform vec3 sigma_t;
uniform float splat_radius;        // the kernel σ (m), or the bounds of a beam's own (splat/beam_width.glsl)
uniform sampler2D scene_distance;  // G-buffer (distance to the first surface, KIND_*, material, 0)
#ifdef BEAM_PILOT
uniform float gbuffer_step;        // the G-buffer's pixels per pilot pixel
uniform float pixel_angle;         // a pilot pixel's width per metre of distance
flat in float v_half;
#endif

flat in vec3 v_start;
flat in vec3 v_dir;
flat in float v_length;
flat in float v_sigma0;
flat in float v_rate;
flat in vec3 v_power;
flat in float v_boxed;  // 1: the kernel integrated over each pixel's area; 0: point-sampled

out vec4 out_color;

float std_cdf(float z) { return 0.5 + 0.5 * erf_approx(z * 0.7071067811865476); }
float std_pdf(float z) { return 0.3989422804014327 * exp(-0.5 * z * z); }

// The kernel's CDF (z in σ: the Gaussian cut at ±TRUNCATION, divided by the mass kept) and
// its integral H(z) = ∫_{−∞}^{z} C = [z·(Φ(z) − Φ(−T)) + φ(z) − φ(T)] / AXIS_KEPT_MASS within
// the cut (0 below it, z above it: the kernel's mean is 0).
float kernel_cdf(float z) {
    return (std_cdf(clamp(z, -TRUNCATION, TRUNCATION)) - std_cdf(-TRUNCATION)) / AXIS_KEPT_MASS;
}
float kernel_cdf_integral(float z) {
    if (z <= -TRUNCATION) return 0.0;
    if (z >= TRUNCATION) return z;
    return (z * (std_cdf(z) - std_cdf(-TRUNCATION)) + std_pdf(z) - std_pdf(TRUNCATION)) / AXIS_KEPT_MASS;
}

// The 1-D kernel (per σ) averaged over a pixel across which the distance to the beam is
// z + α·x + β·y, x and y uniform in [−½, ½] (a pixel is a square; its distance to a line
// is then the sum of two uniform offsets): the kernel convolved with two boxes, by the
// second difference of H. A box under 1% of σ is taken as none (its variance α²/12 is
// then under 1e-5 of the kernel's). The average is even in z, and is taken at −|z|: there
// H is at most hi + φ(0), not |z| + hi (H(z) = z + H(−z)), so the second difference, a
// float32 cancellation, loses less at the kernel's cut; what it still loses (ulps of H over
// a·b) is held at 0 from below: the average of a kernel ≥ 0 is ≥ 0. (Measured on 300 beams
// of power 1e12: pixels of −2.2e7 beside a peak of 2.9e12, −4.4e5 at −|z|, none clamped;
// compare refuses a frame with a negative pixel.)
float beam_pixel_mass(float z, float alpha, float beta) {
    float a = max(alpha, beta), b = min(alpha, beta);
    z = -abs(z);
    if (a < 0.01) return z < -TRUNCATION ? 0.0 : std_pdf(z) / AXIS_KEPT_MASS;
    if (b < 0.01) return max(kernel_cdf(z + 0.5 * a) - kernel_cdf(z - 0.5 * a), 0.0) / a;
    float hi = 0.5 * (a + b), lo = 0.5 * (a - b);
    return max(kernel_cdf_integral(z + hi) - kernel_cdf_integral(z + lo) - kernel_cdf_integral(z - lo)
               + kernel_cdf_integral(z - hi), 0.0) / (a * b);
}

void main() {
    vec3 ray = pixel_ray_through(gl_FragCoord.xy, viewport, view_proj);
    vec3 w0 = eye - v_start;
    // the signed distance between pixel ray and beam and its change per pixel (m), taken
    // before any fragment of the 2×2 quad is discarded (v_boxed is the primitive's: uniform there)
    float u_signed = 0.0;
    vec2 du = vec2(0.0);
    if (v_boxed > 0.5) {
        vec3 normal = cross(ray, v_dir);
        u_signed = dot(w0, normal) * inversesqrt(max(dot(normal, normal), 1e-16));
        du = vec2(dFdx(u_signed), dFdy(u_signed));
    }
    float b = dot(ray, v_dir);
    float sin2 = 1.0 - b * b;
    if (sin2 < 1e-8) discard;  // along the beam: a set of rays of measure zero
    float d_ray = dot(ray, w0), d_beam = dot(v_dir, w0);
    float t = (b * d_beam - d_ray) / sin2;  // closest approach along the pixel ray (m from the eye)
    float s = (d_beam - b * d_ray) / sin2;  // ... along the beam (m from its start)
    float sin_theta = sqrt(sin2);
    // the part of the beam in front of the camera and of its first surface along this ray:
    // the beam's point at s' lies at depth s'·b − d_ray along it, which must be in (0, far]
#ifdef BEAM_PILOT
    vec4 g = texelFetch(scene_distance, ivec2(gl_FragCoord.xy * gbuffer_step), 0);
#else
    vec4 g = texelFetch(scene_distance, ivec2(gl_FragCoord.xy), 0);
#endif
    float far = gbuffer_kind(g) != KIND_NONE ? g.x : 1e30;
    float s_lo = 0.0, s_hi = v_length;
    if (abs(b) > 1e-6) {
        float at_eye = d_ray / b, at_far = (far + d_ray) / b;
        s_lo = max(s_lo, min(at_eye, at_far));
        s_hi = min(s_hi, max(at_eye, at_far));
    } else if (!(-d_ray > 0.0 && -d_ray <= far)) {
        discard;
    }
#ifdef BEAM_CLOSEST_DEPTH
    if (t <= 0.0 || t > far) discard;  // a test's wrong estimator: the closest approach's depth alone
    s_lo = 0.0;
    s_hi = v_length;
#endif
    if (s_hi <= s_lo) discard;
    // the kernel where the ray passes (at the nearer end past the visible part's ends)
    float on_beam = clamp(s, s_lo, s_hi);
    float sigma = beam_sigma(v_sigma0, v_rate, on_beam, splat_radius);
    float reach = TRUNCATION * sigma / sin_theta;  // the ends' Gaussians, cut as the kernel
    if (s < s_lo - reach || s > s_hi + reach) discard;
    float k;
    if (v_boxed > 0.5) {
        vec2 box = abs(du) / sigma;
        float z = u_signed / sigma;
        if (abs(z) > TRUNCATION + 0.5 * (box.x + box.y)) discard;
        k = beam_pixel_mass(z, box.x, box.y) / sigma;
    } else {
        vec3 gap = w0 + t * ray - s * v_dir;
        float u2 = dot(gap, gap);
        float R = TRUNCATION * sigma;
        if (u2 > R * R) discard;
        k = exp(-u2 / (2.0 * sigma * sigma)) / (2.5066282746310002 * sigma * AXIS_KEPT_MASS);
    }
    float along = sin_theta * 0.7071067811865476 / sigma;
    // ≥ 0 (s_hi > s_lo), but two erf near 1 may round the other way
    float ends = max(0.5 * (erf_approx((s_hi - s) * along) - erf_approx((s_lo - s) * along)), 0.0);
#ifdef BEAM_NO_SINE
    float jacobian = 1.0;
#else
    float jacobian = 1.0 / sin_theta;
#endif
    // the transmittance along the beam and from there to the eye, at the closest approach
    // within the visible part (past its ends, where its Gaussians still reach, at the end itself)
#if defined(HETEROGENEOUS)
    vec3 x = v_start + on_beam * v_dir;
#ifdef EXACT_MARCH
    int knot = beam_knot_before(v_length, on_beam);
    float from = beam_knot(v_length, knot);
    float on_beam_depth = v_knots[knot] + exact_depth(v_start + v_dir * from, v_dir, on_beam - from);
#else
    float on_beam_depth = march_depth(v_start, v_dir, on_beam, march_steps);
#endif
#ifdef EXACT_EYE  // along this pixel's ray to x's depth on it, from the knot before (splat/eye_knots.glsl)
    float t_x = dot(x - eye, ray);
    int eye_knot_j = eye_knot_before(t_x);
    float eye_from = eye_knot(eye_knot_j);
    float to_eye = eye_knots[eye_knot_slot(ivec2(gl_FragCoord.xy), eye_knot_j, ivec2(viewport))]
                   + exact_depth(eye + ray * eye_from, ray, t_x - eye_from);
#else
    float to_eye = camera_depth(x);
#endif
    vec3 transmittance = exp(-sigma_t * (on_beam_depth + to_eye));
    vec3 scattering = sigma_s * density_at(x);
#elif defined(BEAM_NO_CAMERA_TRANSMITTANCE)
    vec3 transmittance = exp(-sigma_t * on_beam);
    vec3 scattering = sigma_s;
#else
    vec3 transmittance = exp(-sigma_t * (on_beam + distance(v_start + on_beam * v_dir, eye)));
    vec3 scattering = sigma_s;
#endif
    vec3 radiance = v_power * scattering * phase_eval(-b) * transmittance * k * ends * jacobian;
#ifdef BEAM_PILOT
    float y = dot(radiance, vec3(0.2126, 0.7152, 0.0722));
    float sigma_px = sigma / (pixel_angle * max(t, 1e-6));
    out_color = vec4(y * (1.0 - v_half), y * v_half, y * sigma_px * sigma_px, 0.0);
#else
    out_color = vec4(radiance, 1.0);
#endif
}
