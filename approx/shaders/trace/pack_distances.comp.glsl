// The distance channel of the light-map texels as a compact float array: the
// intersection search reads only distances, 4 bytes instead of 16 per texel.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Texels { vec4 map_texels[]; };
layout(std430, binding = 1) writeonly buffer Distances { float map_dist[]; };
uniform uint count;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < count) map_dist[i] = map_texels[i].x;
}
