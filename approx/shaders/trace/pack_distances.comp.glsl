// One light map copied into the tracer's storage buffers: all texels (vec4), the
// geometric normals (vec2, octahedral), with PACK_PRIMITIVE the primitive ids (+ 1;
// 0 = none: only the start rule `id` reads them) and the distance channel alone as a compact
// float array (the intersection search reads only distances: 4 bytes instead of
// 16 per texel), plus the exact range of
// the map's surface distances (texels > 0), which lets the tracer skip maps a
// segment's distance range cannot meet. Positive floats order like their bit
// patterns, so the range is reduced with uint atomics. Run once per map.
//
// Each invocation copies PACK_TEXELS texels, strided by the whole dispatch (neighbouring
// invocations touch neighbouring texels), keeps their range in registers and adds it
// with one atomic pair: no shared memory and no barriers, which llvmpipe runs as
// coroutine switches (the shared-memory tree took 72 ns a texel there; docs/history.md
// "The method's own frame").
// PACK_BLOCK, PACK_TEXELS: defined by approx/trace.py (PACK), which sizes the dispatch
layout(local_size_x = PACK_BLOCK) in;
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

void main() {
    uint count = uint(res * res);
    uint stride = gl_NumWorkGroups.x * uint(PACK_BLOCK);
    uint lo = 0xFFFFFFFFu, hi = 0u;
    for (uint i = gl_GlobalInvocationID.x; i < count; i += stride) {
        ivec2 at = ivec2(int(i) % res, int(i) / res);
        vec4 texel = texelFetch(map_texture, at, 0);
        vec4 geometric = texelFetch(geometric_texture, at, 0);
        uint slot = map_index * count + i;
        map_texels[slot] = texel;
        map_geometric[slot] = geometric.xy;
#ifdef PACK_PRIMITIVE
        map_primitive[slot] = geometric.z;
#endif
        map_dist[slot] = texel.x;
        if (texel.x > 0.0) {
            lo = min(lo, floatBitsToUint(texel.x));
            hi = max(hi, floatBitsToUint(texel.x));
        }
    }
    if (hi > 0u) {
        atomicMin(map_range[map_index].x, lo);
        atomicMax(map_range[map_index].y, hi);
    }
}
