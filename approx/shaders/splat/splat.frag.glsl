// Closed-form line integral of the photon's 3D Gaussian along the pixel ray,
// over the visible part [0, s_max] (s_max: distance to the first surface, so the
// splat is depth-tested against the scene):
//   ∫ K ds = exp(-b²/2σ²)/(2πσ²) · ½[erf((s_max - s_c)/(√2σ)) + erf(s_c/(√2σ))]
// with s_c the ray parameter closest to the centre and b the distance there. The
// kernel is cut at b = TRUNCATION·σ and divided by the mass it keeps,
// 1 − exp(−TRUNCATION²/2), so a splat's integral over the image stays exact.
uniform vec3 eye;
#include "common/erf.glsl"
#include "splat/kernel.glsl"
#include "common/kinds.glsl"

uniform sampler2D scene_distance;  // G-buffer (distance to the first surface, KIND_*, material, 0)

in vec3 v_center;
in vec3 v_corner;
flat in vec3 v_weight;
#ifdef SPLAT_ADAPTIVE
flat in float v_sigma;  // the splat's kernel standard deviation (m)
flat in float v_pixel;  // a pixel's width at the splat (m); 0: the paper's point-sampled kernel
flat in vec2 v_center_px;
uniform float pixel_angle;  // 2·tan(fov_y/2)/height
uniform vec2 viewport;
#define SIGMA v_sigma
#else
uniform float splat_radius;
#define SIGMA splat_radius
#endif

out vec4 out_color;

void main() {
    vec3 ray = normalize(v_corner - eye);  // perspective-correct point on the billboard at this pixel centre
    vec4 g = texelFetch(scene_distance, ivec2(gl_FragCoord.xy), 0);
    float s_max = gbuffer_kind(g) != KIND_NONE ? g.x : 1e30;
    vec3 oc = v_center - eye;
    float s_c = dot(oc, ray);
    // b² from the perpendicular offset itself: dot(oc, oc) − s_c² cancels catastrophically
    // in float32 (|oc|² ≈ 20 m² has an ulp of 2e-6 m², the size of b² for σ of a few mm).
    vec3 perp = oc - s_c * ray;
    float b2 = dot(perp, perp);
    float inv_sqrt2_sigma = 0.7071067811865476 / SIGMA;
    // Both erf terms are 1 to float precision more than 6σ from the ends of [0, s_max].
    float along = (s_c > 6.0 * SIGMA && s_max - s_c > 6.0 * SIGMA)
        ? 1.0
        : 0.5 * (erf_approx((s_max - s_c) * inv_sqrt2_sigma) + erf_approx(s_c * inv_sqrt2_sigma));
    float k;
#ifdef SPLAT_ADAPTIVE
    if (v_pixel > 0.0) {
        // The kernel's mass over this pixel (in window coordinates the splat plane maps to
        // pixels by a similarity: a circular Gaussian of σ / pixel; the masses of all
        // pixels sum to 1), spread over the pixel's solid angle times the splat's distance²
        // (pixel_angle²·cos³θ·d²): Σ L·Ω is the point photon's Φ/d², for any σ.
        // Each axis is cut at ±TRUNCATION·σ and divided by the mass kept (kernel.glsl), so
        // the billboard needs to reach only that far (splat.vert.glsl).
        vec2 offset = gl_FragCoord.xy - v_center_px;
        float s = 0.7071067811865476 * v_pixel / SIGMA;  // 1/(√2 σ) in pixels
        float cut = TRUNCATION * SIGMA / v_pixel;        // the square's half-side (pixels)
        vec2 lo = clamp(offset - 0.5, -cut, cut);
        vec2 hi = clamp(offset + 0.5, -cut, cut);
        vec2 mass = 0.5 * (vec2(erf_approx(hi.x * s), erf_approx(hi.y * s))
                           - vec2(erf_approx(lo.x * s), erf_approx(lo.y * s))) / AXIS_KEPT_MASS;
        vec2 plane = (gl_FragCoord.xy - 0.5 * viewport) * pixel_angle;  // the pixel on the image plane at 1 m
        float cos_theta = inversesqrt(1.0 + dot(plane, plane));
        k = mass.x * mass.y / (v_pixel * v_pixel * cos_theta * cos_theta * cos_theta) * along;
    } else
#endif
    {
        if (b2 > TRUNCATION * TRUNCATION * SIGMA * SIGMA) discard;
        k = exp(-b2 / (2.0 * SIGMA * SIGMA)) / (6.283185307179586 * SIGMA * SIGMA * KEPT_MASS) * along;
    }
    out_color = vec4(v_weight * k, 1.0);
}
