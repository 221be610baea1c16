// Emission (paper §4.3): one photon per covered texel of the photon_res² light
// map, at the first surface, with power I·falloff(ω)·ΔΩ(texel) (exact texel
// solid angle from the CPU) times the medium's transmittance exp(−σt·r) over the
// distance r from the light to that surface (HETEROGENEOUS: exp(−σt·∫ρ) by march_steps
// midpoint samples), then the first specular interaction.
// Adaptive emission (EMISSION_ADAPTIVE, approx.emission): slot i emits in the texel
// the host drew for it in proportion to the texel's importance, at a uniformly random
// point of that texel (the slot's Owen-scrambled Sobol point with EMISSION_JITTER_SOBOL),
// with the power times the slot's weight 1/(expected photons of
// the texel), so every texel's expected power is the uniform photon's.
// emission_jitter (uniform emission): the photon starts at its texel's centre (paper), at
// a uniformly random point u(seed, texel, 0, 2..3) (EMISSION_JITTER_RANDOM) or at the
// Owen-scrambled Sobol point of its texel's Morton index, scrambled by the seed
// (EMISSION_JITTER_SOBOL; scenes/sobol.py).
// DIFFERENTIALS (splat = adaptive, beam_width = differential): each photon's ray
// differential at its first surface (common/differential.glsl).
// FRESNEL_SPLITS (fresnel_splits = k): the dispatch's z is the batch; every batch emits the
// same photon per texel, each splitting at its first surface as common/split.glsl says.
#include "common/rng.glsl"
#include "common/sobol.glsl"
#include "common/optics.glsl"
#include "common/photon.glsl"
#include "common/start_offset.glsl"
#include "emission/map.glsl"
#ifdef HETEROGENEOUS  // a density grid scales the medium: the light's path marched (common/density.glsl)
#include "common/density.glsl"
uniform int march_steps;
#endif

layout(local_size_x = 8, local_size_y = 8) in;

uniform float ior[MAX_MATERIALS];
#include "common/interaction.glsl"
uniform uint batch_slots;        // photon_res²: the slots of one batch (common/split.glsl)
#include "common/split.glsl"

uniform sampler2D emission_geometric;  // its octahedral outward geometric normal, primitive id + 1
uniform uint seed;
uniform vec3 sigma_t;            // the medium between the light and the first surface

layout(std430, binding = 0) writeonly buffer Photons { Photon photons[]; };

#ifdef EMISSION_ADAPTIVE
// per slot: the texel (row-major; -1: none) and the weight, approx.emission.SLOT_DTYPE
struct Slot { int texel; float weight; };
layout(std430, binding = 3) readonly buffer Slots { Slot slots[]; };
#endif

#ifdef DIFFERENTIALS
// per photon: (footprint, rate), scenes.formats.DIFFERENTIAL_DTYPE
layout(std430, binding = 2) writeonly buffer Differentials { vec2 differentials[]; };
#include "common/differential.glsl"
// The first surface's outward curvature at `texel` along `axis`, from the neighbour on
// +axis or, where that one does not continue the surface (emission/map.glsl), the one on
// -axis; `found` says whether either served. `spacing`: the texels' distance apart there.
float emission_curvature(ivec2 texel, vec4 map, vec3 p0, vec3 n0, ivec2 axis, float spacing, out bool found) {
    for (int k = 0; k < 2; ++k) {
        ivec2 t = texel + (k == 0 ? axis : -axis);
        if (!on_grid(t)) continue;
        vec4 m = texelFetch(emission_map, t, 0);
        if (!continues(map, p0, t, m, 8.0 * spacing)) continue;
        found = true;
        return curvature_between(p0, n0, map_point(t, m.r), octa_decode(m.ba));
    }
    found = false;
    return 0.0;
}
#endif

void main() {
    ivec2 slot = ivec2(gl_GlobalInvocationID.xy);
    if (slot.x >= photon_res || slot.y >= photon_res) return;
    uint index = uint(slot.y * photon_res + slot.x);  // the texel's (adaptive emission: the slot's) photon
    uint slot_index = gl_GlobalInvocationID.z * batch_slots + index;  // its slot in batch z (common/split.glsl)

    Photon ph;
    ph.pos = vec4(0.0, 0.0, 0.0, -1.0);
    ph.dir = vec4(0.0, 0.0, 0.0, float(STATUS_DEAD));
    ph.power = vec4(0.0);
    vec2 diff = vec2(0.0);

#ifdef EMISSION_ADAPTIVE
    Slot drawn = slots[index];
    ivec2 texel = ivec2(drawn.texel % photon_res, drawn.texel / photon_res);
#ifdef EMISSION_JITTER_SOBOL
    vec2 within = sobol_2d(seed, index);
#else
    vec2 within = vec2(rng_uniform(seed, index, 0u, 2u), rng_uniform(seed, index, 0u, 3u));
#endif
    float weight = drawn.weight;
    vec4 map = drawn.texel >= 0 ? texelFetch(emission_map, texel, 0) : vec4(0.0);
#else
    ivec2 texel = slot;
#if defined(EMISSION_SHIFT)
    vec2 within = vec2(0.5 + EMISSION_SHIFT);  // a test's wrong grid: the emission term's negative control
#elif defined(EMISSION_JITTER_RANDOM)
    vec2 within = vec2(rng_uniform(seed, index, 0u, 2u), rng_uniform(seed, index, 0u, 3u));
#elif defined(EMISSION_JITTER_SOBOL)
    vec2 within = sobol_2d(seed, morton(slot));
#else
    vec2 within = vec2(0.5);
#endif
    vec4 map = texelFetch(emission_map, texel, 0);
#endif
    uint texel_index = uint(texel.y * photon_res + texel.x);
    vec2 plane = texel_plane(texel, within);
    vec3 d = normalize(light_basis * vec3(plane, 1.0));
    float falloff = spot_falloff(d);
    float split_factor;
    bool emitted = split_kept(seed, slot_index, split_factor);  // split_every (common/split.glsl)
    if (map.r > 0.0 && falloff > 0.0 && emitted) {
        vec4 geometric_id = texelFetch(emission_geometric, texel, 0);
        vec3 geometric = octa_decode(geometric_id.xy);
        float r = map.r;
#if defined(EMISSION_ADAPTIVE) || defined(EMISSION_SHIFT) || defined(EMISSION_JITTER_RANDOM) || defined(EMISSION_JITTER_SOBOL)
        // a ray off the texel's centre meets its surface in its tangent plane (the map holds the centre's point)
        float along = dot(d, geometric);
        float t = abs(along) > 1e-3 ? dot(map_point(texel, map.r) - light_position, geometric) / along : -1.0;
        if (t > 0.5 * map.r && t < 2.0 * map.r) r = t;
#endif
#if defined(HETEROGENEOUS) && defined(EXACT_MARCH)  // the decomposition's control: the march made exact
        vec3 transmittance = exp(-sigma_t * exact_depth(light_position, d, r));
#elif defined(HETEROGENEOUS)
        vec3 transmittance = exp(-sigma_t * march_depth(light_position, d, r, march_steps));
#else
        vec3 transmittance = exp(-sigma_t * r);
#endif
#ifdef EMISSION_ADAPTIVE
        vec3 power = light_intensity * falloff * solid_angle[texel_index] * weight * transmittance;
#else
        vec3 power = light_intensity * falloff * solid_angle[texel_index] * transmittance;
#endif
        power *= split_factor;
        int inside = -1;
        vec3 d_in = d;
        uint flags = surface_interaction(d, power, inside, octa_decode(map.ba), geometric, int(map.g + 0.5),
                                         split_number(fresnel_uniform(seed, slot_index, 0u), slot_index, 0u));
        vec3 from_light = d_in * r;
#ifdef DIFFERENTIALS
        // From the light the photons' rays spread by the grid's angular spacing (with adaptive
        // emission over √(expected photons of the texel) = √weight of it).
        float spread = ray_spread(plane);
        vec3 n0 = octa_decode(map.ba);
        vec3 centre = map_point(texel, map.r);
        bool fx, fy;
        float kx = emission_curvature(texel, map, centre, n0, ivec2(1, 0), spread * map.r, fx);
        float ky = emission_curvature(texel, map, centre, n0, ivec2(0, 1), spread * map.r, fy);
        float kappa = (fx || fy) ? (kx + ky) / float(int(fx) + int(fy)) : 0.0;
#ifdef EMISSION_ADAPTIVE
        spread *= sqrt(weight);
#endif
        float w = spread * r;
        diff = vec2(w, interaction_rate(spread, w, d_in, d, n0, kappa, int(map.g + 0.5), flags));
#endif
        ph.pos = vec4(light_position + from_light, float(inside));
        ph.dir = vec4(d, float(STATUS_SURFACE));
#if defined(START_RULE_ID)
        ph.power = vec4(power, geometric_id.z);  // the start rule `id`: the triangle left
#elif defined(START_RULE_FACING)
        ph.power = vec4(power, 0.0);             // the start rule `facing`: no offset
#else
        ph.power = vec4(power, start_offset(from_light, d, geometric));
#endif
    }
    photons[slot_index] = ph;
#ifdef DIFFERENTIALS
    differentials[slot_index] = diff;
#endif
}
