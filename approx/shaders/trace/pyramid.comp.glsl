// One level of the min–max distance pyramid the `hiz` search traverses (Tevs,
// Ihrke & Seidel, I3D 2008; Uludag, GPU Pro 5): cell (x, y) of level L covers
// the texels (x·2^L ... x·2^L + 2^L − 1, likewise y) of one light map and holds
//     (lo, hi) = (min, max) of the covered texels' distances to the light,
// lo negated when any texel of the cell is uncovered (or outside the map), and
// (0, 0) when none is covered. Level 1 is built from the maps' distances (0 =
// uncovered), level L > 1 from level L − 1. One dispatch per level for all maps
// (z = map). Layout: map-major, each map's levels 1..top one after another
// (`pyramid_offset`, approx/trace.py pyramid_layout), rows bottom-up.
layout(local_size_x = 8, local_size_y = 8) in;

uniform int light_res;
uniform int level;            // L >= 1: the level written
uniform int source_offset;    // offset of level L − 1 within a map's block (L > 1)
uniform int target_offset;    // offset of level L
uniform int map_stride;       // cells of one map's levels 1..top

layout(std430, binding = 0) readonly buffer LightMapDistances { float map_dist[]; };
layout(std430, binding = 1) buffer Pyramid { vec2 pyramid[]; };

// Cells per side at level L (cell = texel >> L).
int cells(int L) { return ((light_res - 1) >> L) + 1; }

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    int map = int(gl_GlobalInvocationID.z);
    int n = cells(level);
    if (cell.x >= n || cell.y >= n) return;
    int n_source = cells(level - 1);
    float lo = 3.0e38, hi = 0.0;
    bool partial = false;
    for (int k = 0; k < 4; ++k) {
        ivec2 child = 2 * cell + ivec2(k & 1, k >> 1);
        vec2 value = vec2(0.0);  // (lo, hi) of the child, as stored
        if (child.x < n_source && child.y < n_source) {
            if (level == 1) {
                float d = map_dist[(map * light_res + child.y) * light_res + child.x];
                value = vec2(d, d);
            } else {
                value = pyramid[map * map_stride + source_offset + child.y * n_source + child.x];
            }
        }
        if (value.y <= 0.0) { partial = true; continue; }
        partial = partial || value.x < 0.0;
        lo = min(lo, abs(value.x));
        hi = max(hi, value.y);
    }
    pyramid[map * map_stride + target_offset + cell.y * n + cell.x] = hi > 0.0 ? vec2(partial ? -lo : lo, hi) : vec2(0.0);
}
