// The start offset: how far from the surface a photon leaves the intersection
// search begins, in light-map texel footprints (texel_angle × distance to the light).
//
// A light map holds a surface only at its texel centres: within a texel the map's
// distance is off from the true surface by up to half a texel diagonal times
// tan(theta), theta the angle between the light ray and the surface normal, and
// the start point (a previous estimate) is off by as much. Leaving along d, the
// segment's distance from the surface along the light ray grows at the rate
// |d·n| / cos(theta); it has passed both errors after
//     t = footprint · (START_SLOPE · sin(theta) + START_FLOOR) / |d·n|,
// with START_SLOPE at most 2 · (√2 / 2) (both errors at their bound). START_FLOOR
// covers what the plane model leaves out (curvature across a texel, float rounding);
// START_MAX caps grazing departures, where no offset both avoids the start surface
// and keeps nearby hits. Values: approx/trace.py START_OFFSET (docs/decisions.md "Start offset").
#ifndef VOLCAUSTICS_START_OFFSET_GLSL
#define VOLCAUSTICS_START_OFFSET_GLSL

#ifndef START_SLOPE
#define START_SLOPE 0.7
#endif
#ifndef START_FLOOR
#define START_FLOOR 0.25
#endif
#ifndef START_MAX
#define START_MAX 2.0
#endif

// Offset in texel footprints for a photon at light_to_point (from the light) leaving
// along unit d a surface with unit geometric normal n.
float start_offset(vec3 light_to_point, vec3 d, vec3 n) {
    float cos_theta = abs(dot(normalize(light_to_point), n));
    float sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    float away = abs(dot(d, n));
    return min((START_SLOPE * sin_theta + START_FLOOR) / max(away, 1e-6), START_MAX);
}

#endif
