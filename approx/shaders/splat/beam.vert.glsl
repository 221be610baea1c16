// Photon beams (splat = beams; Jarosz, Nowrouzezahrai, Sadeghi & Jensen 2011, the beam ×
// camera-ray estimator with a 1-D kernel; on the GPU as camera-facing quads: Jarosz et al.
// 2011, "Progressive photon beams"). Each beam, a photon's segment in the medium, is drawn
// as a quad over every pixel whose ray may pass within TRUNCATION·σ of it: at each end of
// the part in front of the camera, the end's tangent cone of radius TRUNCATION·σ cut by
// the plane facing the camera there (as a point splat's billboard), stretched along the
// beam's direction across the view (a trapezoid where the kernel widens along the beam).
// The fragment stage (beam.frag.glsl) does the estimate.
#include "common/photon.glsl"
#include "splat/kernel.glsl"
#include "splat/beam_width.glsl"

uniform mat4 view_proj;
uniform vec3 eye;
uniform float splat_radius;   // kernel standard deviation (m), unless the beam carries its own (then its bounds)
uniform float pixel_angle;    // 2·tan(fov_y/2)/height: a pixel's width per metre of distance

in vec2 in_corner;            // per vertex: (±1, ±1): (start or end, side)
in vec4 in_start_length;      // per instance: Beam.start_length
in vec4 in_dir;               // per instance: Beam.dir
in vec4 in_power;             // per instance: Beam.power

out vec3 v_corner;            // world position on the quad: the pixel ray passes through it
flat out vec3 v_start;
flat out vec3 v_dir;
flat out float v_length;
flat out float v_sigma0;      // the row's own σ at the start (m), 0: splat_radius (splat/beam_width.glsl)
flat out float v_rate;        // ... and its rate along the beam (m/m)
flat out vec3 v_power;
flat out float v_boxed;       // 1: the beam carries its own σ, integrated over each pixel (beam.frag.glsl)

// The beam's clip w (the distance in front of the camera) is affine along it; its part
// with w >= W_NEAR (the projection's near plane) is drawn.
const float W_NEAR = 1e-3;

void main() {
    vec3 a = in_start_length.xyz;
    vec3 d = in_dir.xyz;
    float len = in_start_length.w;
    v_boxed = in_dir.w > 0.0 ? 1.0 : 0.0;
    v_start = a;
    v_dir = d;
    v_length = len;
    v_sigma0 = in_dir.w;
    v_rate = in_power.w;
    v_power = in_power.rgb;
    float wa = (view_proj * vec4(a, 1.0)).w;
    float wb = (view_proj * vec4(a + d * len, 1.0)).w;
    if (!(len > 0.0) || (wa < W_NEAR && wb < W_NEAR)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: no fragments
        v_corner = vec3(0.0);
        return;
    }
    float lo = wa < W_NEAR ? len * (W_NEAR - wa) / (wb - wa) : 0.0;
    float hi = wb < W_NEAR ? len * (W_NEAR - wa) / (wb - wa) : len;
    bool far_end = in_corner.x > 0.0;
    vec3 p = a + d * (far_end ? hi : lo);
    vec3 to_eye = eye - p;
    float dist = length(to_eye);
    vec3 w = to_eye / dist;
    vec3 across = d - dot(d, w) * w;  // the beam's direction as the camera sees it at this end
    float n = length(across);
    across = n > 1e-4 ? across / n : normalize(cross(abs(w.y) < 0.99 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0), w));
    vec3 side = cross(w, across);
    // a radius at each end whose line along the drawn part bounds every kernel between:
    // the widest kernel at both ends (|σ0 + rate·s| clamped is largest at an end), or, where
    // narrower, the ends' floored σ, a convex bound of σ that its chord holds (a trapezoid:
    // a beam that widens along its length shades fewer fragments)
    float widest = max(beam_sigma(in_dir.w, in_power.w, lo, splat_radius),
                       beam_sigma(in_dir.w, in_power.w, hi, splat_radius));
    float sigma = widest;
#ifndef BEAM_RECTANGLE  // a test's control: the widest kernel's rectangle
    if (in_dir.w > 0.0) {
        float at_lo = beam_sigma_floored(in_dir.w, in_power.w, lo, splat_radius);
        float at_hi = beam_sigma_floored(in_dir.w, in_power.w, hi, splat_radius);
        if (at_lo + at_hi < 2.0 * widest) sigma = far_end ? at_hi : at_lo;
    }
#endif
    float R = TRUNCATION * sigma;
    // the tangent cone's radius in the plane facing the camera, 5% and a pixel more: the
    // quad's straight edges between the two ends stay outside the cones between them, and
    // a pixel-integrated kernel's ½·(|α| + |β|) ≤ 0.71 pixel beyond the cut is inside
    float extent = 1.05 * R * dist / sqrt(max(dist * dist - R * R, 1e-4 * R * R)) + pixel_angle * dist;
    v_corner = p + ((far_end ? 1.0 : -1.0) * across + in_corner.y * side) * extent;
    gl_Position = view_proj * vec4(v_corner, 1.0);
}
