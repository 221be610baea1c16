// Emission (paper §4.3): one photon per covered texel of the photon_res² light
// map, at the first surface, with power I·falloff(ω)·ΔΩ(texel) (exact texel
// solid angle from the CPU) times the medium's transmittance exp(−σt·r) over the
// distance r from the light to that surface, then the first specular interaction.
#include "common/rng.glsl"
#include "common/spot.glsl"
#include "common/optics.glsl"
#include "common/octahedral.glsl"
#include "common/photon.glsl"
#include "common/start_offset.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform float ior[MAX_MATERIALS];
#include "common/interaction.glsl"

uniform sampler2D emission_map;  // nearest surface: (distance, material, octahedral shading normal)
uniform sampler2D emission_geometric;  // its octahedral outward geometric normal, primitive id + 1
uniform int photon_res;
uniform float tan_half;          // tan(cutoff): the map's image plane spans [-tan_half, tan_half]²
uniform mat3 light_basis;        // columns: light right, up, spot axis (world)
uniform uint seed;
uniform vec3 sigma_t;            // the medium between the light and the first surface

layout(std430, binding = 0) writeonly buffer Photons { Photon photons[]; };
layout(std430, binding = 1) readonly buffer SolidAngles { float solid_angle[]; };

vec2 texel_plane(ivec2 texel) {
    return ((vec2(texel) + 0.5) / float(photon_res) * 2.0 - 1.0) * tan_half;
}

#ifdef SPLAT_ADAPTIVE
// per photon: (footprint, rate), scenes.formats.DIFFERENTIAL_DTYPE
layout(std430, binding = 2) writeonly buffer Differentials { vec2 differentials[]; };
#include "common/differential.glsl"
// The first surface's outward curvature at `texel` along `axis`, from the neighbour on
// +axis or, where that one is empty, of another material or across a jump in depth
// (a silhouette over a farther surface), the one on -axis; `found` says whether either served.
float emission_curvature(ivec2 texel, vec4 map, vec3 p0, vec3 n0, ivec2 axis, float spacing, out bool found) {
    for (int k = 0; k < 2; ++k) {
        ivec2 t = texel + (k == 0 ? axis : -axis);
        if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(photon_res)))) continue;
        vec4 m = texelFetch(emission_map, t, 0);
        if (m.r <= 0.0 || abs(m.g - map.g) > 0.5) continue;
        vec3 p1 = light_position + normalize(light_basis * vec3(texel_plane(t), 1.0)) * m.r;
        if (distance(p1, p0) > 8.0 * spacing) continue;
        found = true;
        return curvature_between(p0, n0, p1, octa_decode(m.ba));
    }
    found = false;
    return 0.0;
}
#endif

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (texel.x >= photon_res || texel.y >= photon_res) return;
    uint index = uint(texel.y * photon_res + texel.x);
    vec4 map = texelFetch(emission_map, texel, 0);

    Photon ph;
    ph.pos = vec4(0.0, 0.0, 0.0, -1.0);
    ph.dir = vec4(0.0, 0.0, 0.0, float(STATUS_DEAD));
    ph.power = vec4(0.0);

    vec2 diff = vec2(0.0);
    vec2 plane = texel_plane(texel);
    vec3 d = normalize(light_basis * vec3(plane, 1.0));
    float falloff = spot_falloff(d);
    if (map.r > 0.0 && falloff > 0.0) {
        vec3 power = light_intensity * falloff * solid_angle[index] * exp(-sigma_t * map.r);
        int inside = -1;
        vec4 geometric_id = texelFetch(emission_geometric, texel, 0);
        vec3 geometric = octa_decode(geometric_id.xy);
        vec3 d_in = d;
        uint flags = surface_interaction(d, power, inside, octa_decode(map.ba), geometric, int(map.g + 0.5),
                                         rng_uniform(seed, index, 0u, 1u));
        vec3 from_light = normalize(light_basis * vec3(plane, 1.0)) * map.r;
#ifdef SPLAT_ADAPTIVE
        // From the light the photons' rays spread by the grid's angular spacing, 2·tan(cutoff)/N
        // on the image plane, foreshortened by cos² off the axis.
        float spread = 2.0 * tan_half / float(photon_res) / dot(vec3(plane, 1.0), vec3(plane, 1.0));
        float w = spread * map.r;
        vec3 n0 = octa_decode(map.ba);
        bool fx, fy;
        float kx = emission_curvature(texel, map, light_position + from_light, n0, ivec2(1, 0), w, fx);
        float ky = emission_curvature(texel, map, light_position + from_light, n0, ivec2(0, 1), w, fy);
        float kappa = (fx || fy) ? (kx + ky) / float(int(fx) + int(fy)) : 0.0;
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
    photons[index] = ph;
#ifdef SPLAT_ADAPTIVE
    differentials[index] = diff;
#endif
}
