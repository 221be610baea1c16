// Adaptive emission's importance (params `emission` = adaptive; approx.emission): per
// texel of the photon_res² grid, the power a uniform photon would carry, I·falloff·ΔΩ,
// times 1 + EMISSION_GAIN·e, where e in [0, 1] says how much the surface turns there:
// the largest angle between its shading normal and a neighbour's over EMISSION_TEXELS (8)
// times the rays' own spread (a sphere of radius R seen from D turns by D/R ray spreads
// per texel), and 1 at a discontinuity (a neighbour uncovered, of another material or a
// farther surface behind a silhouette). 0 where nothing is hit or the spot is dark.
// The paper's future work: "sharp curvatures are likely to produce visible caustic beams".
#include "common/spot.glsl"
#include "emission/map.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) writeonly buffer Importance { float importance[]; };

#ifndef EMISSION_GAIN
#define EMISSION_GAIN 3.0
#endif
#ifndef EMISSION_TEXELS
#define EMISSION_TEXELS 8.0
#endif

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (texel.x >= photon_res || texel.y >= photon_res) return;
    uint index = uint(texel.y * photon_res + texel.x);
    vec4 map = texelFetch(emission_map, texel, 0);
    vec2 plane = texel_plane(texel, vec2(0.5));
    float falloff = spot_falloff(normalize(light_basis * vec3(plane, 1.0)));
    float q = 0.0;
    if (map.r > 0.0 && falloff > 0.0) {
        float spread = ray_spread(plane);
        vec3 p0 = map_point(texel, map.r);
        vec3 n0 = octa_decode(map.ba);
        float e = 0.0;
        const ivec2 axes[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
        for (int k = 0; k < 4; ++k) {
            ivec2 t = texel + axes[k];
            if (!on_grid(t)) continue;  // the map's border is not the surface's
            vec4 m = texelFetch(emission_map, t, 0);
            if (!continues(map, p0, t, m, 8.0 * spread * map.r)) {
                e = 1.0;
                break;
            }
            e = max(e, length(octa_decode(m.ba) - n0) / (EMISSION_TEXELS * spread));
        }
        q = falloff * solid_angle[index] * (1.0 + EMISSION_GAIN * min(e, 1.0));
    }
    importance[index] = q;
}
