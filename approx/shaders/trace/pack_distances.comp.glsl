// One light map copied into the tracer's storage buffers: all texels (vec4), the
// geometric normals (vec2, octahedral), with PACK_PRIMITIVE the primitive ids (+ 1;
// 0 = none: only the start rule `id` reads them) and the distance channel alone as a compact
// float array (the intersection search reads only distances: 4 bytes instead of
// 16 per texel), plus the exact range of
// the map's surface distances (texels > 0), which lets the tracer skip maps a
// segment's distance range cannot meet. Positive floats order like their bit
// patterns, so the range is reduced with uint atomics. Run once per map.
#define BLOCK 256
layout(local_size_x = BLOCK) in;
uniform sampler2D map_texture;
uniform sampler2D geometric_texture;
uniform int res;
uniform uint map_index;
layout(std430, binding = 0) writeonly buffer Texels { vec4 map_texels[]; };
layout(std430, binding = 1) writeonly buffer Distances { float map_dist[]; };
layout(std430, binding = 2) buffer Ranges { uvec2 map_range[]; };  // (min bits, max bits) per map
layout(std430, binding = 3) writeonly buffer Geometric { vec2 map_geometric[]; };
#ifdef PACK_PRIMITIVE
layout(std430, binding = 4) writeonly buffer Primitive { float map_primitive[]; };
#endif

shared uint lo[BLOCK];
shared uint hi[BLOCK];

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint lane = gl_LocalInvocationID.x;
    uint count = uint(res * res);
    vec4 texel = i < count ? texelFetch(map_texture, ivec2(int(i) % res, int(i) / res), 0) : vec4(0.0);
    if (i < count) {
        map_texels[map_index * count + i] = texel;
        vec4 geometric = texelFetch(geometric_texture, ivec2(int(i) % res, int(i) / res), 0);
        map_geometric[map_index * count + i] = geometric.xy;
#ifdef PACK_PRIMITIVE
        map_primitive[map_index * count + i] = geometric.z;
#endif
        map_dist[map_index * count + i] = texel.x;
    }
    float d = texel.x;
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
        atomicMin(map_range[map_index].x, lo[0]);
        atomicMax(map_range[map_index].y, hi[0]);
    }
}
