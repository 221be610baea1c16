// Photon beams (splat = beams; Jarosz, Nowrouzezahrai, Sadeghi & Jensen 2011, the beam ×
// camera-ray estimator with a 1-D kernel; on the GPU as quads: Jarosz et al. 2011,
// "Progressive photon beams"). Each beam, a photon's segment in the medium, is drawn as a
// quad over every pixel whose ray the fragment stage (beam.frag.glsl) can give a value: a
// ray that passes within R = TRUNCATION·σ of the beam's line where its closest approach
// lies on the beam, or up to R/sin θ beyond an end (the ends' Gaussians): within √2·R of
// that end. Those rays lie inside four planes through the eye: two sides, tangent to the
// balls of the beam's kernel (R along the beam's line past its ends too: the chord of its
// ends' R, raised where a narrowing kernel's line would pass inside an end's R within √2·R
// past it), and two caps, each at the angular extreme, in the plane of the eye and the
// beam, of the ends' balls of c·R (end_reach: R for a beam seen across, up to √2·R for one
// within a few degrees of the view). Their four lines of intersection, the quad's corners,
// are drawn as directions (homogeneous: w = their depth), so that the rasteriser's
// clipping gives the exact cone of rays on the image, whether or not a corner lies in
// front of the camera. Where no such planes exist (the eye inside or between the balls),
// the beam is drawn over the whole image. The beam is first clipped to its part in front
// of the camera (W_NEAR) whose balls can reach the view frustum (its side planes moved out
// by R·√2 and a pixel): the rest can give no pixel a value. Each ball is a pixel wider (a
// pixel-integrated kernel reaches ½·(|α| + |β|) ≤ 0.71 pixel beyond the cut). The
// fragment stage makes its estimate on the ray through the pixel's centre.
// (The quad was built in world space from each end's plane facing the eye: where R neared
// the distance to the eye its corners, 100 times that distance out in two tilted planes,
// fell behind the camera and the whole beam was lost: a caustic of 0 at splat_radius 2 m.)
#include "common/photon.glsl"
#include "splat/kernel.glsl"
#include "splat/beam_width.glsl"
#if defined(HETEROGENEOUS) && defined(EXACT_MARCH)
// The decomposition's control EXACT_MARCH: the depth along the beam exact (common/density.glsl).
// Taken per fragment from the start it cost a walk over every cell plane up to the fragment's
// point; here the beam's exact depth at BEAM_KNOTS points along it, once per vertex, and the
// fragment walks only from the knot before its point (beam.frag.glsl): the same integral.
#include "common/density.glsl"
#include "splat/beam_knots.glsl"
flat out float v_knots[BEAM_KNOTS];
#endif

uniform mat4 view_proj;
uniform vec3 eye;
uniform float splat_radius;   // kernel standard deviation (m), unless the beam carries its own (then its bounds)
uniform float pixel_angle;    // 2·tan(fov_y/2)/height: a pixel's width on the image plane at 1 m

in vec2 in_corner;            // per vertex: (±1, ±1): (start or end, side)
in vec4 in_start_length;      // per instance: Beam.start_length
in vec4 in_dir;               // per instance: Beam.dir
in vec4 in_power;             // per instance: Beam.power

flat out vec3 v_start;
flat out vec3 v_dir;
flat out float v_length;
flat out float v_sigma0;      // the row's own σ at the start (m), 0: splat_radius (splat/beam_width.glsl)
flat out float v_rate;        // ... and its rate along the beam (m/m)
flat out vec3 v_power;
flat out float v_boxed;       // 1: the beam carries its own σ, integrated over each pixel (beam.frag.glsl)
#ifdef BEAM_PILOT
flat out float v_half;        // which half of the beams (alternate rows, in photon order): 0 or 1
#endif

// The beam's clip w (the distance in front of the camera) is affine along it; its part
// with w >= W_NEAR (the projection's near plane) is drawn.
const float W_NEAR = 1e-3;
// The balls' margin: the planes are exact; this is for float rounding in their construction.
const float BALL_MARGIN = 1.01;
const float SQRT2 = 1.4142135623730951;

vec4 vp_row(int i) { return vec4(view_proj[0][i], view_proj[1][i], view_proj[2][i], view_proj[3][i]); }

// [lo, hi] cut to where f0 + f1·s >= 0 (f affine along the beam)
void keep_where(float f0, float f1, inout float lo, inout float hi) {
    if (f1 > 0.0) lo = max(lo, -f0 / f1);
    else if (f1 < 0.0) hi = min(hi, -f0 / f1);
    else if (f0 < 0.0) hi = lo - 1.0;
}

// A ball's angle from the eye: the angle between `axis` and its centre c, plus its half-angle.
float ball_angle(vec3 axis, vec3 c, float r) {
    return atan(length(cross(axis, c)), dot(axis, c)) + asin(r / length(c));
}

// Four planes through the eye around the cone of half-angle H about `axis` (unit): a square
// pyramid holding it; false where the cone is half the view sphere or more.
bool cone_planes(vec3 axis, float H, out vec3 side0, out vec3 side1, out vec3 cap_near, out vec3 cap_far) {
    side0 = side1 = cap_near = cap_far = vec3(0.0);
    if (!(H < 1.55)) return false;
    vec3 u2 = normalize(abs(axis.y) < 0.9 ? cross(axis, vec3(0.0, 1.0, 0.0)) : cross(axis, vec3(1.0, 0.0, 0.0)));
    vec3 k = cross(axis, u2);
    float sH = sin(H), cH = cos(H);
    side0 = sH * axis + cH * k;
    side1 = sH * axis - cH * k;
    cap_near = sH * axis + cH * u2;
    cap_far = sH * axis - cH * u2;
    return true;
}

// Four planes through the eye (unit normals; inside: n·(x − eye) ≥ 0) holding, on a line
// through A and B (relative to the eye), the sides' balls (rA around A, rB around B) and
// the hull between them, and the caps' balls (cap_r0 around C0, cap_r1 around C1, on the
// same line): the sides are tangent to both sides' balls, the caps pass at the extreme
// angles, in the plane of the eye and the line, of all four balls. Where no plane touches
// both sides' balls (a beam seen nearly end-on: one ball's cone holds the other's), a
// pyramid around the cone that holds all four balls. False where there are none: the eye
// is inside a ball, or the balls span half the view sphere.
bool beam_planes(vec3 A, float rA, vec3 B, float rB, vec3 C0, float cap_r0, vec3 C1, float cap_r1,
                 out vec3 side0, out vec3 side1, out vec3 cap_near, out vec3 cap_far) {
    float lA = length(A), lB = length(B);
    side0 = side1 = cap_near = cap_far = vec3(0.0);
    if (!(rA < lA) || !(rB < lB) || !(cap_r0 < length(C0)) || !(cap_r1 < length(C1))) return false;
    vec3 u1 = A / lA;
    vec3 normal = B - dot(B, u1) * u1;
    float b2 = length(normal);
    // the sides: m·A = rA, m·B = rB, |m| = 1 (x along u1, y along the line's normal in the plane)
    float x = rA / lA, y = b2 > 1e-5 * lB ? (rB - x * dot(B, u1)) / b2 : 0.0;
    float z2 = 1.0 - x * x - y * y;
    if (!(b2 > 1e-5 * lB) || !(z2 > 1e-6)) {  // end-on: the cone around all four balls
        vec3 axis = normalize(A / lA + B / lB);
        float H = max(max(ball_angle(axis, A, rA), ball_angle(axis, B, rB)),
                      max(ball_angle(axis, C0, cap_r0), ball_angle(axis, C1, cap_r1)));
        return cone_planes(axis, H, side0, side1, cap_near, cap_far);
    }
    vec3 u2 = normalize(normal);
    vec3 k = cross(u1, u2);
    side0 = x * u1 + y * u2 + sqrt(z2) * k;
    side1 = x * u1 + y * u2 - sqrt(z2) * k;
    // the caps: the angles (from u1 towards u2) that the caps' balls and the sides' span
    float a0 = atan(dot(C0, u2), dot(C0, u1)), a1 = atan(dot(C1, u2), dot(C1, u1)), ab = atan(b2, dot(B, u1));
    float h0 = asin(cap_r0 / length(C0)), h1 = asin(cap_r1 / length(C1));
    float hA = asin(rA / lA), hB = asin(rB / lB);
    float lo = min(min(a0 - h0, a1 - h1), min(-hA, ab - hB));
    float hi = max(max(a0 + h0, a1 + h1), max(hA, ab + hB));
    if (!(hi - lo < 3.1)) return false;
    cap_near = cos(lo) * u2 - sin(lo) * u1;
    cap_far = sin(hi) * u1 - cos(hi) * u2;
    return true;
}

// How far past an end, in R, the rays the estimate reaches lie in the plane of the eye and
// the beam. In a ray's own cross-section they fill a rectangle past the end: R along the
// beam's image and R across it (a ray counts while its closest approach is within R of the
// line and within R/sin θ of the end along it). Seen across, that is R; perspective turns
// the rectangle by τ for rays off the plane, tan τ ≤ sin ψ · cot θ (ψ: their angle off the
// plane, within √2·R of the end; θ: the beam's angle to the view less ψ), which reaches
// R·(cos τ + sin τ) ≤ √2·R. Checked against the rays' extreme angle past an end on 6,000
// random geometries, half of them beams within 20° of the view (docs/decisions.md "Wide
// beams drawn whole"): never beyond it. √2 where the bound does not hold (near the eye).
float end_reach(vec3 end_from_eye, vec3 d, float R) {
    float dist = length(end_from_eye);
    float sin_psi = SQRT2 * R / dist;
    if (!(sin_psi < 0.4)) return SQRT2;
    float theta = atan(length(cross(d, end_from_eye)), abs(dot(d, end_from_eye))) - asin(sin_psi);
    if (!(theta > 0.0)) return SQRT2;
    float tau = atan(sin_psi, tan(theta));
    return tau >= 0.7853981633974483 ? SQRT2 : cos(tau) + sin(tau);
}

// The line where planes p and q meet, its direction inside planes r and t; false if none.
bool corner(vec3 p, vec3 q, vec3 r, vec3 t, out vec3 v) {
    v = cross(p, q);
    float len = length(v);
    if (!(len > 1e-6)) return false;
    v /= len;
    if (dot(v, r) + dot(v, t) < 0.0) v = -v;
    return dot(v, r) > -1e-5 && dot(v, t) > -1e-5;
}

void main() {
    vec3 a = in_start_length.xyz;
    vec3 d = in_dir.xyz;
    float len = in_start_length.w;
    v_boxed = in_dir.w > 0.0 ? 1.0 : 0.0;
#ifdef BEAM_PILOT
    v_half = float(gl_InstanceID & 1);
#endif
    v_start = a;
    v_dir = d;
    v_length = len;
    v_sigma0 = in_dir.w;
    v_rate = in_power.w;
    v_power = in_power.rgb;
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: no fragments, unless drawn below
    if (!(len > 0.0)) return;
    // the widest kernel anywhere on the beam (|σ0 + rate·s| clamped is largest at an end)
    float widest_all = max(beam_sigma(in_dir.w, in_power.w, 0.0, splat_radius),
                           beam_sigma(in_dir.w, in_power.w, len, splat_radius));
    // the part in front of the camera whose balls can reach the frustum (its side planes
    // through the eye, moved out by the widest cap's ball and a pixel at the farther end)
    vec4 row0 = vp_row(0), row1 = vp_row(1), row3 = vp_row(3);
    float lo = 0.0, hi = len;
    keep_where(dot(row3, vec4(a, 1.0)) - W_NEAR, dot(row3.xyz, d), lo, hi);
    float reach = SQRT2 * BALL_MARGIN * TRUNCATION * widest_all
                  + pixel_angle * max(distance(a, eye), distance(a + d * len, eye));
    for (int i = 0; i < 4; i++) {
        vec4 plane = row3 + (i < 2 ? row0 : row1) * (i % 2 == 0 ? 1.0 : -1.0);  // left, right, bottom, top
        float norm = length(plane.xyz);
        keep_where(dot(plane, vec4(a, 1.0)) / norm + reach, dot(plane.xyz, d) / norm, lo, hi);
    }
    if (!(hi > lo)) return;
#if defined(HETEROGENEOUS) && defined(EXACT_MARCH)
    v_knots[0] = 0.0;
    for (int j = 1; j < BEAM_KNOTS; ++j) {
        float from = beam_knot(len, j - 1);
        v_knots[j] = v_knots[j - 1] + exact_depth(a + d * from, d, beam_knot(len, j) - from);
    }
#endif
    // a radius at each end whose line along the drawn part bounds every kernel between:
    // the widest kernel at both ends, or, where narrower, the ends' floored σ, a convex
    // bound of σ that its chord holds (a trapezoid: a beam that widens along its length
    // shades fewer fragments)
    float widest = max(beam_sigma(in_dir.w, in_power.w, lo, splat_radius),
                       beam_sigma(in_dir.w, in_power.w, hi, splat_radius));
    float sigma_lo = widest, sigma_hi = widest;
#ifndef BEAM_RECTANGLE  // a test's control: the widest kernel's rectangle
    if (in_dir.w > 0.0) {
        float at_lo = beam_sigma_floored(in_dir.w, in_power.w, lo, splat_radius);
        float at_hi = beam_sigma_floored(in_dir.w, in_power.w, hi, splat_radius);
        if (at_lo + at_hi < 2.0 * widest) {
            sigma_lo = at_lo;
            sigma_hi = at_hi;
        }
    }
#endif
    // each ball a pixel wider (a pixel at its distance); the sides' balls at the ends of the
    // line c·R past the ends (end_reach), R on the chord raised by what a narrowing kernel
    // needs there; the caps' balls c·(R + a pixel) around the ends
    float R_lo = BALL_MARGIN * TRUNCATION * sigma_lo, R_hi = BALL_MARGIN * TRUNCATION * sigma_hi;
    vec3 A = a + d * lo - eye, B = a + d * hi - eye;
    float R_lo_px = R_lo + pixel_angle * length(A), R_hi_px = R_hi + pixel_angle * length(B);
    float c_lo = end_reach(A, d, R_lo_px), c_hi = end_reach(B, d, R_hi_px);
    float past_lo = c_lo * R_lo, past_hi = c_hi * R_hi;
    float slope = (R_hi - R_lo) / (hi - lo);
    float raise = abs(slope) * (R_lo < R_hi ? past_lo : past_hi);
    vec3 A_side = A - d * past_lo, B_side = B + d * past_hi;
    float r_lo = R_lo + raise - slope * past_lo, r_hi = R_hi + raise + slope * past_hi;
    vec3 side0, side1, cap_near, cap_far;
    bool drawn = beam_planes(A_side, r_lo + pixel_angle * length(A_side), B_side, r_hi + pixel_angle * length(B_side),
                             A, c_lo * R_lo_px, B, c_hi * R_hi_px,
                             side0, side1, cap_near, cap_far);
    // the four corners (each vertex finds all four, so that a beam is drawn whole or over the image)
    vec3 v00, v01, v10, v11;
    drawn = drawn && corner(side0, cap_near, side1, cap_far, v00) && corner(side1, cap_near, side0, cap_far, v01)
            && corner(side0, cap_far, side1, cap_near, v10) && corner(side1, cap_far, side0, cap_near, v11);
#ifdef BEAM_FULLSCREEN  // a test's control: every beam over the whole image
    drawn = false;
#endif
    if (drawn) {
        vec3 v = in_corner.x < 0.0 ? (in_corner.y < 0.0 ? v00 : v01) : (in_corner.y < 0.0 ? v10 : v11);
        gl_Position = vec4(dot(v, row0.xyz), dot(v, row1.xyz), 0.0, dot(v, row3.xyz));
    } else {
        gl_Position = vec4(in_corner, 0.0, 1.0);  // the whole image
    }
}
