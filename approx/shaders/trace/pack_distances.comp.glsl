// The distance channel of the light-map texels as a compact float array (the
// intersection search reads only distances: 4 bytes instead of 16 per texel),
// and per map the exact range of its surface distances (texels > 0), which lets
// the tracer skip maps a segment's distance range cannot meet. Positive floats
// order like their bit patterns, so the range is reduced with uint atomics.
// BLOCK texels per work group never straddle two maps (light_res² is a multiple).
#define BLOCK 256
layout(local_size_x = BLOCK) in;
layout(std430, binding = 0) readonly buffer Texels { vec4 map_texels[]; };
layout(std430, binding = 1) writeonly buffer Distances { float map_dist[]; };
layout(std430, binding = 2) buffer Ranges { uvec2 map_range[]; };  // (min bits, max bits) per map
uniform uint count;
uniform uint texels_per_map;

shared uint lo[BLOCK];
shared uint hi[BLOCK];

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint lane = gl_LocalInvocationID.x;
    float d = i < count ? map_texels[i].x : 0.0;
    if (i < count) map_dist[i] = d;
    lo[lane] = d > 0.0 ? floatBitsToUint(d) : 0xFFFFFFFFu;
    hi[lane] = d > 0.0 ? floatBitsToUint(d) : 0u;
    barrier();
    for (uint stride = uint(BLOCK) / 2u; stride > 0u; stride >>= 1) {
        if (lane < stride) {
            lo[lane] = min(lo[lane], lo[lane + stride]);
            hi[lane] = max(hi[lane], hi[lane + stride]);
        }
        barrier();
    }
    if (lane == 0u && hi[0] > 0u) {
        uint map = (gl_WorkGroupID.x * uint(BLOCK)) / texels_per_map;
        atomicMin(map_range[map].x, lo[0]);
        atomicMax(map_range[map].y, hi[0]);
    }
}
