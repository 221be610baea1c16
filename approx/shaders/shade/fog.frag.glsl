// Fog (docs/conventions.md): single scattering of direct, unrefracted spot light along the
// camera ray, with volumetric shadows of all objects (Wyman & Ramsey 2008, ray
// marching). The march covers only the part of the ray inside the spot's cutoff
// cone (elsewhere the falloff is 0) and in front of the first surface:
//   L = ∫ σs p(θ) I·falloff(ω)/r² · exp(-σt r) · V(x) · exp(-σt s) ds
// Its FOG_STEPS samples are spaced uniformly in the angle seen from the light,
// s = Δ + D·tan φ (Δ: ray parameter closest to the light, D: that distance), the
// substitution that cancels the 1/r² peak near the light (ds = r²/D dφ); uniform
// steps in s undersample it where the ray passes close to the light.
// HETEROGENEOUS (a density grid): σs(x) = ρ(x)·σs at each sample, and exp(−σt·(r + s)) becomes
// the light's and the camera's transmittance volumes at x (common/volumes.glsl).
#include "common/camera.glsl"
#include "common/spot.glsl"
#include "common/phase.glsl"
#include "common/shadow.glsl"
#include "common/kinds.glsl"
#include "common/box.glsl"
#ifdef HETEROGENEOUS  // σs(x) = ρ(x)·σs; both legs' transmittance from the transmittance volumes
#include "common/density.glsl"
#include "common/volumes.glsl"
#endif

uniform sampler2D gbuffer_geometry;  // (distance to eye, KIND_*, material, 0)
uniform vec3 sigma_s;
uniform vec3 sigma_t;
uniform vec3 scene_min;
uniform vec3 scene_max;

out vec4 out_color;

bool in_cone(vec3 p) {
    vec3 q = p - light_position;
    return dot(q, light_direction) > spot_cos_cutoff * length(q);
}

// Part [s_in, s_out] of the ray o + s r, s in [0, s_end], inside the cutoff cone.
// The cone (half-angle < 90°) is convex, so the part is one interval; it is found
// between the roots of the cone's quadratic by testing sub-interval midpoints.
bool cone_interval(vec3 o, vec3 r, float s_end, out float s_in, out float s_out) {
    vec3 q = o - light_position;
    float c2 = spot_cos_cutoff * spot_cos_cutoff;
    float qa = dot(q, light_direction), ra = dot(r, light_direction);
    float A = ra * ra - c2;
    float B = 2.0 * (qa * ra - c2 * dot(q, r));
    float C = qa * qa - c2 * dot(q, q);
    float cuts[4];
    int n = 0;
    cuts[n++] = 0.0;
    if (abs(A) > 1e-12) {
        float disc = B * B - 4.0 * A * C;
        if (disc >= 0.0) {
            float sq = sqrt(disc);
            float r0 = (-B - sq) / (2.0 * A), r1 = (-B + sq) / (2.0 * A);
            float lo = min(r0, r1), hi = max(r0, r1);
            if (lo > 0.0 && lo < s_end) cuts[n++] = lo;
            if (hi > 0.0 && hi < s_end) cuts[n++] = hi;
        }
    } else if (abs(B) > 1e-12) {
        float r0 = -C / B;
        if (r0 > 0.0 && r0 < s_end) cuts[n++] = r0;
    }
    cuts[n++] = s_end;
    s_in = -1.0;
    s_out = -1.0;
    for (int k = 0; k + 1 < n; ++k) {
        if (in_cone(o + r * (0.5 * (cuts[k] + cuts[k + 1])))) {
            if (s_in < 0.0) s_in = cuts[k];
            s_out = cuts[k + 1];
        }
    }
    return s_in >= 0.0 && s_out > s_in;
}

void main() {
    vec3 r = pixel_ray(gl_FragCoord.xy);
    vec4 g = texelFetch(gbuffer_geometry, ivec2(gl_FragCoord.xy), 0);
    float s_end = gbuffer_kind(g) != KIND_NONE ? g.x : box_exit(eye, r, scene_min, scene_max);
    vec3 radiance = vec3(0.0);
    float s_in, s_out;
    if (cone_interval(eye, r, s_end, s_in, s_out)) {
        float delta = dot(light_position - eye, r);
        float D = max(length(light_position - eye - delta * r), 1e-6);
        float phi_a = atan(s_in - delta, D);
        float phi_b = atan(s_out - delta, D);
        float dphi = (phi_b - phi_a) / float(FOG_STEPS);
        for (int k = 0; k < FOG_STEPS; ++k) {
            float s = delta + D * tan(phi_a + (float(k) + 0.5) * dphi);
            vec3 x = eye + r * s;
            vec3 to_x = x - light_position;
            float dist = length(to_x);
            vec3 w = to_x / dist;
            float vis = light_visibility(x, dist, 0.0);
            if (vis > 0.0) {
                // integrand · ds/dφ with ds/dφ = dist²/D: the 1/dist² cancels
#ifdef HETEROGENEOUS
                radiance += density_at(x) * phase_eval(dot(w, -r)) * spot_falloff(w) / D
                          * exp(-sigma_t * (light_depth(x) + camera_depth(x)));
#else
                radiance += phase_eval(dot(w, -r)) * spot_falloff(w) / D * exp(-sigma_t * (dist + s));
#endif
            }
        }
        radiance *= sigma_s * light_intensity * dphi;
    }
    out_color = vec4(radiance, 1.0);
}
