// One interaction step of the image-based photon tracer (paper §4.1–4.3).
//
// Each photon traces one segment: inside glass towards the exit (up to the
// scene span); in the medium a free-flight distance d = -ln(1 - ξ)/sigma_bar
// drawn from the shared RNG. The first hit on the segment is *estimated* from
// the light maps: per map, PEAK_SAMPLES interior samples, uniform along the
// segment's projection in the light's image, look for the first sign change of
// (distance to the light − map distance); none means no hit on that map; else
// ITERATIONS steps of binary search refine it. The smallest t over the maps wins.
// A hit applies the specular interaction; no hit in the medium moves the photon
// to the collision point (direction kept: single scattering) where it is
// splatted (splat/compact.comp.glsl gathers these from the records). Power follows the deterministic transmittance of every distance
// travelled (medium sigma_t, glass absorption), which together with collisions
// at rate sigma_bar makes the splatted power unbiased (see approx/trace.py).
//
// Maps that cannot hold a crossing are skipped (same result, less work): maps
// with no surface at all, and maps whose surfaces' distance range from the light
// [map_min_dist, map_max_dist] misses the segment's distance range. The maps are
// read as one storage buffer of texels (copied from the rendered textures):
// plain loads, several times faster than texture fetches on llvmpipe.
//
// Defines: MAPS (2 × layers), PEAK_SAMPLES, ITERATIONS, MAX_MATERIALS, and
// FRESNEL_STOCHASTIC when chosen.
#include "common/rng.glsl"
#include "common/optics.glsl"
#include "common/octahedral.glsl"
#include "common/photon.glsl"
#include "common/box.glsl"

layout(local_size_x = 64) in;

uniform float ior[MAX_MATERIALS];
uniform vec3 absorption[MAX_MATERIALS];
#include "common/interaction.glsl"

uniform bool map_used[MAPS];         // the map holds at least one surface texel
uniform float map_min_dist[MAPS];    // bounds of the map's distances to the light
uniform float map_max_dist[MAPS];
uniform mat4 light_view_proj;
uniform vec3 light_position;
uniform int light_res;
uniform float texel_angle;           // 2·tan(cutoff)/light_res: texel footprint per metre of distance
uniform vec3 sigma_t;
uniform float sigma_bar;             // free-flight sampling rate (mean of sigma_t); 0 = vacuum
uniform vec3 scene_min;
uniform vec3 scene_max;
uniform uint seed;
uniform uint step_index;             // 1..steps
uniform uint photon_count;

layout(std430, binding = 0) buffer Photons { Photon photons[]; };
layout(std430, binding = 1) writeonly buffer Records { Record records[]; };
// MAPS maps of light_res² texels, rows bottom-up: (distance, material, octahedral normal), 0 = empty
layout(std430, binding = 2) readonly buffer LightMaps { vec4 map_texels[]; };
// the same maps' distances alone (what the search reads)
layout(std430, binding = 3) readonly buffer LightMapDistances { float map_dist[]; };

uint g_flags;

// A segment o + t·d, t in [t0, t1], with its light-clip coordinates at both ends
// (clip coordinates are affine in t, so no matrix product per sample).
struct Segment {
    vec3 q;   // o − light position
    vec3 d;
    float t0;
    float t1;
    vec4 c0;  // light clip coordinates at t0 (w > 0)
    vec4 c1;  // ... at t1 (w > 0)
};

// Index of the map texel under the segment point at t, or -1 outside the frustum
// (then FLAG_LEFT_FRUSTUM is raised).
int segment_texel_index(int map, Segment s, float t) {
    vec4 clip = mix(s.c0, s.c1, (t - s.t0) / (s.t1 - s.t0));
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) {
        g_flags |= FLAG_LEFT_FRUSTUM;
        return -1;
    }
    ivec2 texel = ivec2(uv * float(light_res));
    return (map * light_res + texel.y) * light_res + texel.x;
}

// Texel under the segment point at t: (distance, material, octahedral normal); 0 if none.
vec4 segment_texel(int map, Segment s, float t) {
    int index = segment_texel_index(map, s, t);
    return index < 0 ? vec4(0.0) : map_texels[index];
}

// f(t) = (distance to the light) − (map distance); valid = covered texel.
float segment_f(int map, Segment s, float t, out bool valid) {
    int index = segment_texel_index(map, s, t);
    float map_distance = index < 0 ? 0.0 : map_dist[index];
    valid = map_distance > 0.0;
    return length(s.q + s.d * t) - map_distance;
}

// Segment parameter for a fraction lam of the segment's projection in the light
// image (perspective-correct: clip w is linear in t, screen position is not).
float screen_uniform_t(float lam, Segment s) {
    float mu = (lam / s.c1.w) / ((1.0 - lam) / s.c0.w + lam / s.c1.w);
    return mix(s.t0, s.t1, mu);
}

// First sign change on the map within [t0, t1]; returns t or -1, and the map texel
// at t (the surface crossed).
float estimate_on_map(int map, Segment s, out vec4 texel) {
    texel = vec4(0.0);
    bool prev_valid;
    float prev_t = s.t0;
    float prev_f = segment_f(map, s, s.t0, prev_valid);
    for (int j = 1; j <= PEAK_SAMPLES + 1; ++j) {
        float t = j == PEAK_SAMPLES + 1 ? s.t1 : screen_uniform_t(float(j) / float(PEAK_SAMPLES + 1), s);
        bool valid;
        float f = segment_f(map, s, t, valid);
        if (valid && prev_valid && ((f > 0.0) != (prev_f > 0.0))) {
            float a = prev_t, b = t;
            bool a_positive = prev_f > 0.0;
            for (int k = 0; k < ITERATIONS; ++k) {
                float mid = 0.5 * (a + b);
                bool v;
                float fm = segment_f(map, s, mid, v);
                // An uncovered midpoint counts as the start's side: the crossing is beyond it.
                if (v && ((fm > 0.0) != a_positive)) b = mid; else a = mid;
            }
            texel = segment_texel(map, s, b);  // the texel beyond the crossing holds the surface crossed
            return 0.5 * (a + b);
        }
        prev_t = t;
        prev_f = f;
        prev_valid = valid;
    }
    return -1.0;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= photon_count) return;
    Photon ph = photons[i];
    Record rec;
    rec.start_maxlen = vec4(ph.pos.xyz, 0.0);
    rec.dir_t = vec4(ph.dir.xyz, -1.0);
    rec.normal_map = vec4(0.0, 0.0, 0.0, -1.0);
    rec.end_status = vec4(ph.pos.xyz, float(STATUS_DEAD));
    rec.power_inside = vec4(ph.power.rgb, ph.pos.w);
    rec.extra = vec4(0.0, -1.0, 0.0, 0.0);
    rec.power_start = vec4(ph.power.rgb, 0.0);
    int status = int(ph.dir.w + 0.5);
    if (status != STATUS_SURFACE && status != STATUS_COLLIDED) {
        ph.dir.w = float(STATUS_DEAD);
        photons[i] = ph;
        records[i] = rec;
        return;
    }

    vec3 o = ph.pos.xyz;
    vec3 d = ph.dir.xyz;
    vec3 power = ph.power.rgb;
    int inside = int(round(ph.pos.w));
    g_flags = 0u;

    // --- segment: free flight in the medium, or the way out of the glass
    float span = box_exit(o, d, scene_min, scene_max);
    float max_len = span;
    if (inside < 0 && sigma_bar > 0.0) {
        max_len = -log(1.0 - rng_uniform(seed, i, step_index, 0u)) / sigma_bar;
    }
    float search = min(max_len, span);

    // --- intersection estimation over all light maps
    // Leave the surface we start on: the maps hold it to within a texel, so the search
    // starts a few texel footprints away (measured on an index-matched sphere at
    // light_res 1024: 1 footprint loses 17% of the caustic to false re-hits of the exit
    // surface, 3 lose 2.5%, 5 lose 1%; larger offsets start to skip thin features).
    float t_eps = 5.0 * texel_angle * length(o - light_position);
    vec4 c0 = light_view_proj * vec4(o, 1.0);
    vec4 c1 = light_view_proj * vec4(o + d * search, 1.0);
    float w_min = 1e-4 * max(c0.w, 1e-3);
    float t1 = search;
    if (c1.w < w_min && c0.w > w_min) {  // keep the part in front of the light
        t1 = search * (c0.w - w_min) / (c0.w - c1.w);
    }
    float best_t = -1.0;
    int best_map = -1;
    vec4 best_texel = vec4(0.0);
    if (c0.w > w_min && t1 > t_eps) {
        Segment seg;
        seg.q = o - light_position;
        seg.d = d;
        seg.t0 = t_eps;
        seg.t1 = t1;
        seg.c0 = mix(c0, c1, t_eps / search);
        seg.c1 = mix(c0, c1, t1 / search);
        // distance range of the segment from the light: closest point, farthest end
        float t_close = clamp(-dot(seg.q, d), t_eps, t1);
        float r_min = length(seg.q + d * t_close);
        float r_max = max(length(seg.q + d * t_eps), length(seg.q + d * t1));
        for (int m = 0; m < MAPS; ++m) {
            if (!map_used[m] || r_max < map_min_dist[m] || r_min > map_max_dist[m]) continue;
            vec4 texel;
            float t = estimate_on_map(m, seg, texel);
            if (t >= 0.0 && (best_t < 0.0 || t < best_t)) {
                best_t = t;
                best_map = m;
                best_texel = texel;
            }
        }
    }

    // --- outcome
    vec3 end;
    int material_hit = -1;
    vec3 normal = vec3(0.0);
    if (best_t >= 0.0) {
        end = o + d * best_t;
        power *= exp(-(inside >= 0 ? absorption[inside] : sigma_t) * best_t);
        normal = octa_decode(best_texel.ba);
        material_hit = int(best_texel.g + 0.5);
        g_flags |= surface_interaction(d, power, inside, normal, material_hit,
                                       rng_uniform(seed, i, step_index, 1u));
        status = STATUS_SURFACE;
    } else if (inside >= 0) {
        end = o + d * search;
        status = STATUS_LOST;
    } else if (max_len <= span) {
        end = o + d * max_len;
        power *= exp(-sigma_t * max_len);
        status = STATUS_COLLIDED;
    } else {
        end = o + d * span;
        status = STATUS_LEFT_SCENE;
    }

    ph.pos = vec4(end, float(inside));
    ph.dir = vec4(d, float(status));
    ph.power = vec4(power, 0.0);
    photons[i] = ph;

    rec.start_maxlen.w = max_len;
    rec.dir_t.w = best_t;
    rec.normal_map = vec4(normal, float(best_map));
    rec.end_status = vec4(end, float(status));
    rec.power_inside.rgb = power;
    rec.extra = vec4(float(g_flags), float(material_hit), search, 0.0);
    records[i] = rec;
}
