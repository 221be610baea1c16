// The emission map as emission and its importance pass read it: the nearest surface
// per texel of the photon_res² grid over the spot's image plane.
#ifndef VOLCAUSTICS_EMISSION_MAP_GLSL
#define VOLCAUSTICS_EMISSION_MAP_GLSL

#include "common/octahedral.glsl"
#include "common/spot.glsl"

uniform sampler2D emission_map;  // nearest surface: (distance, material, octahedral shading normal)
uniform int photon_res;
uniform float tan_half;          // tan(cutoff): the map's image plane spans [-tan_half, tan_half]²
uniform mat3 light_basis;        // columns: light right, up, spot axis (world)

layout(std430, binding = 1) readonly buffer SolidAngles { float solid_angle[]; };

// A point of the image plane, (0, 0) to (1, 1) across texel `texel` ((0.5, 0.5): its centre).
vec2 texel_plane(ivec2 texel, vec2 within) {
    return ((vec2(texel) + within) / float(photon_res) * 2.0 - 1.0) * tan_half;
}

// The angle between neighbouring photons' rays at image-plane point `plane`: the grid's
// spacing 2·tan(cutoff)/N, foreshortened by cos² off the axis.
float ray_spread(vec2 plane) {
    return 2.0 * tan_half / float(photon_res) / dot(vec3(plane, 1.0), vec3(plane, 1.0));
}

// The surface point the emission map holds at `texel` (its centre's ray at the stored distance).
vec3 map_point(ivec2 texel, float distance_to_light) {
    return light_position + normalize(light_basis * vec3(texel_plane(texel, vec2(0.5)), 1.0)) * distance_to_light;
}

// Whether the neighbour `m` at `t` of the surface (p0, material) continues it: covered, of
// the same material and no farther than `jump` (no silhouette over a farther surface).
bool continues(vec4 map, vec3 p0, ivec2 t, vec4 m, float jump) {
    return m.r > 0.0 && abs(m.g - map.g) <= 0.5 && distance(map_point(t, m.r), p0) <= jump;
}

bool on_grid(ivec2 t) {
    return all(greaterThanEqual(t, ivec2(0))) && all(lessThan(t, ivec2(photon_res)));
}

#endif
