// One interaction step of the image-based photon tracer (paper §4.1–4.3).
//
// Each photon traces one segment: inside glass towards the exit (up to the
// scene span); in the medium a free-flight distance d = -ln(1 - ξ)/sigma_bar
// drawn from the shared RNG. The search only looks where the light maps exist
// (docs/conventions.md): the segment is clipped to the light frustum first (Liang–Barsky
// on its light clip coordinates, which are affine in t), so no sample is wasted
// outside. The first hit on the clipped segment is *estimated* from the light
// maps, per map by the search the parameter `search` selects: `bisection` (paper
// §4.1) or `secant` (trace/search_samples.glsl), `dda` or `hiz`
// (trace/search_texels.glsl). The smallest t over the maps wins. A hit applies
// the specular interaction; no hit in the medium moves the photon to the
// collision point (direction kept: single scattering) where it is splatted
// (splat/compact.comp.glsl gathers these from the records). Power follows the
// deterministic transmittance of every distance travelled (medium sigma_t, glass
// absorption), which together with collisions at rate sigma_bar makes the
// splatted power unbiased (see approx/trace.py).
//
// Maps that cannot hold a crossing are skipped (same result, less work): maps
// with no surface at all, and maps whose surfaces' distance range from the light
// [map_min_dist, map_max_dist] misses the segment's distance range. The maps are
// read as storage buffers of texels (copied from the rendered textures): plain
// loads, several times faster than texture fetches on llvmpipe.
//
// A segment must not find the surface it leaves again (`start_rule`). `offset`
// (the default): the search starts a little way from it (the start offset,
// common/start_offset.glsl): its distance to the maps' picture of that surface
// must first exceed the maps' own error there; inside glass, a segment with
// nothing beyond its offset searches within it (FLAG_WITHIN_OFFSET). `id`
// (START_RULE_ID): the search starts at the surface and passes over crossings
// onto the triangle it leaves (the maps carry primitive ids; photon.power.w
// carries the start triangle's id + 1 instead of the offset). `facing`
// (START_RULE_FACING): no offset either; crossings onto faces the photon cannot meet
// from its side (outside: along their outward normal; inside: against it) are passed
// over, which the surface left and its smooth neighbours always are.
//
// Defines: MAPS (2 × layers), PEAK_SAMPLES, ITERATIONS, MAX_MATERIALS, SEARCH_*
// (one of BISECTION, SECANT, DDA, HIZ), the start-offset constants, START_RULE_ID or START_RULE_FACING,
// CROSSING_SURFACE (with CROSSING_TEXELS), FRESNEL_STOCHASTIC and CLIP_TO_OBJECTS when chosen;
// SPLAT_BEAMS (splat = beams): no free flight in the medium, a segment runs to the next
// surface or the medium's end, and splat/compact.comp.glsl makes it a beam.
// DIFFERENTIALS (splat = adaptive, beam_width = differential): the photons carry ray
// differentials through every step; BEAM_DIFFERENTIAL also keeps each photon's at its
// segment's start (the beam's footprint there and its rate along it) for the compaction.
// HETEROGENEOUS (a density grid, common/density.glsl): free flights by delta tracking through
// the grid of majorants at rate ρ(x)·sigma_bar, and a segment's transmittance from
// march_steps midpoint samples of ρ (a fixed march: the approximation the harness
// measures); the tracking's tentative collisions and the march's samples are its medium reads.
// Where the driver has subgroups (GL_ARB_shader_ballot, 64-bit ballots), the loop work
// is also counted in lockstep: a subgroup runs until its longest search ends.
#extension GL_ARB_shader_ballot : enable
#extension GL_ARB_gpu_shader_int64 : enable
#if !defined(SEARCH_BISECTION) && !defined(SEARCH_SECANT) && !defined(SEARCH_DDA) && !defined(SEARCH_HIZ)
#define SEARCH_BISECTION 1
#endif
#include "common/rng.glsl"
#include "common/optics.glsl"
#include "common/octahedral.glsl"
#include "common/photon.glsl"
#include "common/start_offset.glsl"
#include "common/box.glsl"
#ifdef HETEROGENEOUS  // a density grid scales the medium (common/density.glsl): delta tracking, marched transmittance
#define DELTA_TRACKING 1
#include "common/density.glsl"
uniform int march_steps;             // midpoint samples of ρ for a segment's transmittance
#ifdef EXACT_MARCH  // the decomposition's control: a segment's transmittance exact (its march term)
#define SEGMENT_DEPTH(o, d, len) exact_depth(o, d, len)
#else
#define SEGMENT_DEPTH(o, d, len) (g_medium += uint(march_steps), march_depth(o, d, len, march_steps))
#endif
#endif

layout(local_size_x = 64) in;

uniform float ior[MAX_MATERIALS];
uniform vec3 absorption[MAX_MATERIALS];
#include "common/interaction.glsl"
uniform uint batch_slots;  // photon_res²: the slots of one batch (common/split.glsl)
#include "common/split.glsl"

// per map the exact (min, max) of its surface distances as float bits (the pack pass's uint
// atomics; max 0: no surface), read here, never on the host (approx.trace.MapBuffers)
layout(std430, binding = 10) readonly buffer MapRanges { uvec2 map_range_bits[]; };
bool map_used[MAPS];                 // the map holds at least one surface texel
float map_min_dist[MAPS];            // bounds of the map's distances to the light, a little slack for rounding
float map_max_dist[MAPS];

// map_used, map_min_dist, map_max_dist from the ranges, the slack (1 ∓ 1e-5) taken in double
// and rounded once to float, as the host computed it before (so the records did not change)
void load_map_ranges() {
    for (int m = 0; m < MAPS; ++m) {
        uvec2 bits = map_range_bits[m];
        map_used[m] = bits.y != 0u;
        map_min_dist[m] = map_used[m] ? float(double(uintBitsToFloat(bits.x)) * (1.0lf - 1.0e-5lf)) : 0.0;
        map_max_dist[m] = map_used[m] ? float(double(uintBitsToFloat(bits.y)) * (1.0lf + 1.0e-5lf)) : 0.0;
    }
}
uniform mat4 light_view_proj;
uniform mat3 light_basis;            // columns: light right, up, spot axis (world): texel directions
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
// the same maps' outward geometric normals (octahedral): inside/outside after a hit
layout(std430, binding = 4) readonly buffer LightMapGeometric { vec2 map_geometric[]; };
#ifdef START_RULE_ID
// the same maps' primitive ids + 1 (0 = none): the start rule `id`
layout(std430, binding = 5) readonly buffer LightMapPrimitive { float map_primitive[]; };
#endif

#ifdef DIFFERENTIALS
// per photon: (footprint, rate), scenes.formats.DIFFERENTIAL_DTYPE
layout(std430, binding = 7) buffer Differentials { vec2 differentials[]; };
#include "common/differential.glsl"
#endif
#ifdef BEAM_DIFFERENTIAL
layout(std430, binding = 9) writeonly buffer SegmentDifferentials { vec2 segment_differentials[]; };
#endif

// the trace loop's work per step, three counters a step (approx.cost: lookups, one atomic add
// per photon; lockstep_lookups, one per subgroup: its longest search × its size, what a SIMD
// machine spends on it, since every lane waits for the last; without subgroups the photons'
// own; medium_reads, a heterogeneous medium's samples of ρ, one atomic add per photon that
// read any), read once after the frame
layout(std430, binding = 8) buffer Work { uint work[]; };
#define WORK_LOOKUPS work[3u * (step_index - 1u)]
#define WORK_LOCKSTEP work[3u * (step_index - 1u) + 1u]
#define WORK_MEDIUM work[3u * (step_index - 1u) + 2u]

uint g_flags;
uint g_map_reads;  // map texels the search read for this segment (map_reads: cost that travels across hardware)
uint g_lookups;    // map distances the search looked up, registers included: the search loops' iterations
uint g_medium;     // samples of a heterogeneous medium's ρ: delta tracking's tentative collisions, the march's
float g_start_id;  // start rule `id`: primitive id + 1 of the triangle the segment leaves (0 none)
vec3 g_dir;        // start rule `facing`: the segment's direction ...
bool g_inside;     // ... and whether it runs inside glass

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

// Index of the map texel under the segment point at t, or -1 outside the maps (only
// through rounding: segments are clipped to the frustum).
int segment_texel_index(int map, Segment s, float t) {
    vec4 clip = mix(s.c0, s.c1, (t - s.t0) / (s.t1 - s.t0));
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) return -1;
    ivec2 texel = ivec2(uv * float(light_res));
    return (map * light_res + texel.y) * light_res + texel.x;
}

// The two latest texels read, kept in registers: a search that comes back to one (a
// bisection's last steps alternate between the two texels beside the crossing) reads
// no memory for it, so map_reads does not count it.
int g_kept_index[2] = int[2](-1, -1);
float g_kept_dist[2];

// The map distance of texel index (>= 0): from the registers, else one map read.
float map_distance_at(int index) {
    ++g_lookups;
    if (index == g_kept_index[0]) return g_kept_dist[0];
    if (index == g_kept_index[1]) return g_kept_dist[1];
    ++g_map_reads;
    g_kept_index[1] = g_kept_index[0];
    g_kept_dist[1] = g_kept_dist[0];
    g_kept_index[0] = index;
    g_kept_dist[0] = map_dist[index];
    return g_kept_dist[0];
}

// f(t) = (distance to the light) − (map distance); valid = covered texel; index: the
// texel read (-1 none).
float segment_f(int map, Segment s, float t, out bool valid, out int index) {
    index = segment_texel_index(map, s, t);
    float map_distance = index < 0 ? 0.0 : map_distance_at(index);
    valid = map_distance > 0.0;
    return length(s.q + s.d * t) - map_distance;
}

float segment_f(int map, Segment s, float t, out bool valid) {
    int index;
    return segment_f(map, s, t, valid, index);
}

// Does the start rule pass over a crossing onto the texel (index)? `id`: it is the
// triangle the segment leaves (its primitive id: one more map read). `facing`: the
// photon cannot meet that face from its side — a closed surface is met from outside
// against its outward geometric normal and from inside along it — which the surface
// just left and its neighbours always fail (its geometric normal: one more map read).
// Under `offset` never (no read).
bool is_start_surface(int index) {
#if defined(START_RULE_ID)
    if (g_start_id <= 0.0 || index < 0) return false;
    ++g_map_reads;
    return map_primitive[index] == g_start_id;
#elif defined(START_RULE_FACING)
    if (index < 0) return false;
    ++g_map_reads;
    return (dot(g_dir, octa_decode(map_geometric[index])) > 0.0) != g_inside;
#else
    return false;
#endif
}

// Is a crossing at t onto the texel (index) passed over? Onto the start surface (the
// start rule), or — `crossing` = surface — where the segment is not at the texel's
// surface: f changed sign between texels of two surfaces (a jump in the map, e.g. at a
// silhouette over a farther surface), not at a surface. The segment is at it when its
// distance to the light is within CROSSING_TEXELS footprints · (1 + tan θ) of the
// texel's (θ: between the light ray and the texel's geometric normal; the surface's
// distance changes by about tan θ footprints across one texel): the thickness test of
// screen-space ray tracers (McGuire & Mara, JCGT 2014), here from the surface's own
// slope. One more map read (the geometric normal). Under `sign` (the paper) never.
bool passed_over(int index, Segment s, float t) {
    if (is_start_surface(index)) return true;
#ifdef CROSSING_SURFACE
    if (index < 0) return false;
    ++g_map_reads;
    float D = map_dist[index];
    vec3 to_point = s.q + s.d * t;
    float r = length(to_point);
    float cos_theta = clamp(abs(dot(to_point / r, octa_decode(map_geometric[index]))), 0.1, 1.0);
    float tan_theta = sqrt(1.0 - cos_theta * cos_theta) / cos_theta;
    return abs(r - D) > CROSSING_TEXELS * texel_angle * D * (1.0 + tan_theta);
#else
    return false;
#endif
}

#if defined(SEARCH_DDA) || defined(SEARCH_HIZ)
#include "trace/search_texels.glsl"
#else
#include "trace/search_samples.glsl"
#endif

// Keep the part of [lo, hi] where a + b·t >= 0 (one plane of Liang–Barsky clipping).
void clip_plane(float a, float b, inout float lo, inout float hi) {
    if (b == 0.0) {
        if (a < 0.0) hi = -1.0;
        return;
    }
    float t = -a / b;
    if (b > 0.0) lo = max(lo, t); else hi = min(hi, t);
}

// Clip [lo, hi] of o + t·d to the light frustum: light clip coordinates c(t), affine
// in t (c0 at t = 0, c1 at t = len), must satisfy |x|, |y| <= (1 − margin)·w (margin:
// a quarter texel, so every sample falls on a texel) and w >= w_min (in front of the light).
void clip_to_frustum(vec4 c0, vec4 c1, float len, float w_min, inout float lo, inout float hi) {
    vec4 slope = (c1 - c0) / len;
    float keep = 1.0 - 0.5 / float(light_res);
    clip_plane(keep * c0.w - c0.x, keep * slope.w - slope.x, lo, hi);
    clip_plane(keep * c0.w + c0.x, keep * slope.w + slope.x, lo, hi);
    clip_plane(keep * c0.w - c0.y, keep * slope.w - slope.y, lo, hi);
    clip_plane(keep * c0.w + c0.y, keep * slope.w + slope.y, lo, hi);
    clip_plane(c0.w - w_min, slope.w, lo, hi);
}

#ifdef CLIP_TO_OBJECTS
uniform vec3 objects_min;  // bounding box of the specular objects (slightly padded)
uniform vec3 objects_max;

// Clip [lo, hi] of o + t·d to the specular objects' bounding box (slab test).
void clip_to_objects(vec3 o, vec3 d, inout float lo, inout float hi) {
    vec3 inv = 1.0 / d;
    vec3 ta = (objects_min - o) * inv, tb = (objects_max - o) * inv;
    vec3 t_near = min(ta, tb), t_far = max(ta, tb);
    lo = max(lo, max(max(t_near.x, t_near.y), t_near.z));
    hi = min(hi, min(min(t_far.x, t_far.y), t_far.z));
}
#endif

// Smallest estimated hit over all maps on [t0, t1] of o + t·d (light clip coordinates
// c0 at t = 0, c1 at t = search); -1 if none, with the map and the index of its texel.
float search_maps(vec3 o, vec3 d, vec4 c0, vec4 c1, float search, float t0, float t1,
                  out int best_map, out int best_index) {
    float best_t = -1.0;
    best_map = -1;
    best_index = -1;
    if (!(t1 > t0)) return best_t;
    Segment seg;
    seg.q = o - light_position;
    seg.d = d;
    seg.t0 = t0;
    seg.t1 = t1;
    seg.c0 = mix(c0, c1, t0 / search);
    seg.c1 = mix(c0, c1, t1 / search);
    // distance range of the segment from the light: closest point, farthest end
    float t_close = clamp(-dot(seg.q, d), t0, t1);
    float r_min = length(seg.q + d * t_close);
    float r_max = max(length(seg.q + d * t0), length(seg.q + d * t1));
    for (int m = 0; m < MAPS; ++m) {
        if (!map_used[m] || r_max < map_min_dist[m] || r_min > map_max_dist[m]) continue;
        int index;
        float t = estimate_on_map(m, seg, index);
        if (t >= 0.0 && (best_t < 0.0 || t < best_t)) {
            best_t = t;
            best_map = m;
            best_index = index;
        }
    }
    return best_t;
}

#ifdef DIFFERENTIALS
// World position of map texel `index` holding distance r (its ray from the light).
vec3 map_texel_point(int index, float r) {
    int x = index % light_res, y = (index / light_res) % light_res;
    float tan_half = 0.5 * texel_angle * float(light_res);
    vec2 plane = ((vec2(x, y) + 0.5) / float(light_res) * 2.0 - 1.0) * tan_half;
    return light_position + normalize(light_basis * vec3(plane, 1.0)) * r;
}

// The crossed surface's outward curvature at map texel `index` (its texel `texel`) along
// one axis of the map, from the neighbour on +axis or, where that one is empty, of
// another material or across a jump in depth, the one on -axis (one map read each);
// `found` says whether either served.
float map_curvature(int index, vec4 texel, ivec2 axis, out bool found) {
    int x = index % light_res, y = (index / light_res) % light_res;
    vec3 p0 = map_texel_point(index, texel.r);
    float spacing = texel_angle * texel.r;
    for (int k = 0; k < 2; ++k) {
        ivec2 t = ivec2(x, y) + (k == 0 ? axis : -axis);
        if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(light_res)))) continue;
        int other = index + (t.y - y) * light_res + (t.x - x);
        ++g_map_reads;
        vec4 m = map_texels[other];
        if (m.r <= 0.0 || abs(m.g - texel.g) > 0.5) continue;
        vec3 p1 = map_texel_point(other, m.r);
        if (distance(p1, p0) > 8.0 * spacing) continue;
        found = true;
        return curvature_between(p0, octa_decode(texel.ba), p1, octa_decode(m.ba));
    }
    found = false;
    return 0.0;
}
#endif

// The trace loop's work of this photon's subgroup in lockstep (see Work), added once by
// its first active invocation; every invocation that reaches the end calls it.
void count_lockstep_work() {
#if defined(GL_ARB_shader_ballot) && defined(GL_ARB_gpu_shader_int64)
    uvec2 lanes = unpackUint2x32(ballotARB(true));
    uint longest = 0u;
    for (int half_ = 0; half_ < 2; ++half_) {
        uint bits = lanes[half_];
        while (bits != 0u) {  // the same bits on every active lane: a uniform loop
            uint lane = uint(findLSB(bits) + 32 * half_);
            longest = max(longest, readInvocationARB(g_lookups, lane));
            bits &= bits - 1u;
        }
    }
    uint first = lanes.x != 0u ? uint(findLSB(lanes.x)) : uint(findLSB(lanes.y) + 32);
    if (gl_SubGroupInvocationARB == first) atomicAdd(WORK_LOCKSTEP, longest * gl_SubGroupSizeARB);
#else
    atomicAdd(WORK_LOCKSTEP, g_lookups);
#endif
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= photon_count) return;
    load_map_ranges();
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

#ifdef DIFFERENTIALS
    vec2 diff = differentials[i];
#endif
#ifdef BEAM_DIFFERENTIAL
    segment_differentials[i] = diff;  // the beam's footprint at its start, and its rate along it
#endif
    vec3 o = ph.pos.xyz;
    vec3 d = ph.dir.xyz;
    vec3 power = ph.power.rgb;
    int inside = int(round(ph.pos.w));
    g_flags = 0u;
    g_map_reads = 0u;
    g_lookups = 0u;
    g_medium = 0u;

    // --- segment: free flight in the medium, or the way out of the glass
    float span = box_exit(o, d, scene_min, scene_max);
    float max_len = span;
#ifndef SPLAT_BEAMS
    if (inside < 0 && sigma_bar > 0.0) {
#ifdef HETEROGENEOUS  // the first collision at rate ρ(x)·sigma_bar, or none before the box's end
        uint tentative;
        float collision = delta_track(o, d, span, sigma_bar, seed, i, step_index, tentative);
        max_len = collision >= 0.0 ? collision : 2.0 * span + 1.0;
        g_medium += tentative;
#else
        max_len = -log(1.0 - rng_uniform(seed, i, step_index, 0u)) / sigma_bar;
#endif
    }
#endif  // splat = beams: no free flight; the whole segment to the next surface is a beam
    float search = min(max_len, span);

    // --- intersection estimation over all light maps, on the part of [t_eps, search]
    // inside the light frustum (and the objects' box); ph.power.w carries the start
    // offset in light-map texel footprints (0 after a medium collision)
    float footprint = texel_angle * length(o - light_position);
    g_dir = d;
    g_inside = inside >= 0;
#if defined(START_RULE_ID)
    g_start_id = ph.power.w;
    float t_eps = 0.0;
#elif defined(START_RULE_FACING)
    g_start_id = 0.0;
    float t_eps = 0.0;
#else
    g_start_id = 0.0;
    float t_eps = ph.power.w * footprint;
#endif
    vec4 c0 = light_view_proj * vec4(o, 1.0);
    vec4 c1 = light_view_proj * vec4(o + d * search, 1.0);
    float w_min = 1e-4 * max(max(c0.w, c1.w), 1e-3);
    float t0 = t_eps, t1 = search;
    if (search > 0.0) clip_to_frustum(c0, c1, search, w_min, t0, t1);
    if (t0 > t_eps || t1 < search) g_flags |= FLAG_LEFT_FRUSTUM;
#ifdef CLIP_TO_OBJECTS
    clip_to_objects(o, d, t0, t1);
#endif
    int best_map, best_index;
    float best_t = search_maps(o, d, c0, c1, search, t0, t1, best_map, best_index);
    // A photon inside glass must leave it: when nothing was found beyond the start offset,
    // the exit may lie within it (a thin wedge of glass entered at a grazing angle next to
    // a silhouette): search there as well, from a hundredth of the offset.
    if (best_t < 0.0 && inside >= 0 && t_eps > 0.0 && search > 0.0) {
        float u0 = 0.01 * t_eps, u1 = min(t_eps, search);
        clip_to_frustum(c0, c1, search, w_min, u0, u1);
        best_t = search_maps(o, d, c0, c1, search, u0, u1, best_map, best_index);
        if (best_t >= 0.0) g_flags |= FLAG_WITHIN_OFFSET;
    }

    // --- outcome
    vec3 end;
    float next_offset = 0.0;  // start offset of the next segment (texel footprints); `id`: its start triangle
    int material_hit = -1;
    vec3 normal = vec3(0.0);
    if (best_t >= 0.0) {
        // the surface crossed: its texel (one map read)
        if (best_index >= 0) ++g_map_reads;
        vec4 best_texel = best_index >= 0 ? map_texels[best_index] : vec4(0.0);
        vec2 best_geometric = best_index >= 0 ? map_geometric[best_index] : vec2(0.0);
        end = o + d * best_t;
#ifdef HETEROGENEOUS
        power *= inside >= 0 ? exp(-absorption[inside] * best_t) : exp(-sigma_t * SEGMENT_DEPTH(o, d, best_t));
#else
        power *= exp(-(inside >= 0 ? absorption[inside] : sigma_t) * best_t);
#endif
        normal = octa_decode(best_texel.ba);
        vec3 geometric = octa_decode(best_geometric);
        material_hit = int(best_texel.g + 0.5);
        vec3 d_in = d;
        uint interaction = surface_interaction(d, power, inside, normal, geometric, material_hit,
                                               split_number(fresnel_uniform(seed, i, step_index), i, step_index));
        g_flags |= interaction;
#ifdef DIFFERENTIALS
        diff.x += diff.y * best_t;
        float kappa = 0.0;
        if (best_index >= 0) {
            bool fx, fy;
            float kx = map_curvature(best_index, best_texel, ivec2(1, 0), fx);
            float ky = map_curvature(best_index, best_texel, ivec2(0, 1), fy);
            kappa = (fx || fy) ? (kx + ky) / float(int(fx) + int(fy)) : 0.0;
        }
        diff.y = interaction_rate(diff.y, diff.x, d_in, d, normal, kappa, material_hit, interaction);
#endif
#if defined(START_RULE_ID)
        next_offset = best_index >= 0 ? map_primitive[best_index] : 0.0;
#elif defined(START_RULE_FACING)
        next_offset = 0.0;
#else
        next_offset = start_offset(end - light_position, d, geometric);
#endif
        status = STATUS_SURFACE;
    } else if (inside >= 0) {
        end = o + d * search;
        status = STATUS_LOST;
#ifndef SPLAT_BEAMS
    } else if (max_len <= span) {
        end = o + d * max_len;
#ifdef HETEROGENEOUS
        power *= exp(-sigma_t * SEGMENT_DEPTH(o, d, max_len));
#else
        power *= exp(-sigma_t * max_len);
#endif
        status = STATUS_COLLIDED;
#ifdef DIFFERENTIALS
        diff.x += diff.y * max_len;  // the footprint where it is splatted (compact.comp.glsl)
#endif
#endif
    } else {
        end = o + d * span;
        status = STATUS_LEFT_SCENE;
    }

    ph.pos = vec4(end, float(inside));
    ph.dir = vec4(d, float(status));
    ph.power = vec4(power, next_offset);
    photons[i] = ph;
#ifdef DIFFERENTIALS
    differentials[i] = diff;
#endif

    rec.start_maxlen.w = max_len;
    rec.dir_t.w = best_t;
    rec.normal_map = vec4(normal, float(best_map));
    rec.end_status = vec4(end, float(status));
    rec.power_inside.rgb = power;
    rec.extra = vec4(float(g_flags), float(material_hit), search, t_eps);
    rec.power_start.w = float(g_map_reads);
    records[i] = rec;
    atomicAdd(WORK_LOOKUPS, g_lookups);
    if (g_medium > 0u) atomicAdd(WORK_MEDIUM, g_medium);
    count_lockstep_work();
}
