// The texel-walking searches of one map (part of trace/trace.comp.glsl): `dda` and
// `hiz`. Both find the first crossing of the segment with the map's surface taken as
// what the map holds, one distance per texel: exact at the map's resolution.
//
// `dda` visits every texel the segment's projection crosses, in order, with the
// segment-parameter interval it spends there (perspective-correct: the projection's
// crossing of a texel edge x = X solves an affine equation in the clip coordinates;
// McGuire & Mara, JCGT 2014, step in screen space the same way). In a covered texel of
// distance D the crossing is either at its entry, where f = r − D changes sign from the
// previous covered texel (an edge of the map's surface), or inside it, where the
// segment's distance to the light r(t) = |q + d·t| meets D (a root of a quadratic).
// As in the sampled searches, a crossing counts within a covered run only.
//
// `hiz` walks the same texels but skips whole cells of a min–max pyramid of the map
// (trace/pyramid.comp.glsl; Tevs, Ihrke & Seidel, I3D 2008; Uludag, GPU Pro 5):
// coarse to fine, a cell is skipped when no crossing can lie in it and the texel walk
// would leave the same state after it: an empty cell; or a fully covered cell whose
// distance range [lo, hi] the segment's range of r over the cell misses (the sign of
// f is then constant there) with the same sign as the covered run it continues. After
// a skip the walk climbs a level, after a texel or a refused cell it descends, so it
// ends on the texel `dda` ends on. Cell exits are computed at the cell's edge line,
// the coordinate along that edge clamped into the cell (the precision fix of Hi-Z
// traversals: rounding never moves the walk back or into a cell it did not reach).
//
// map_reads: one per texel visited, one per pyramid cell read.

#ifdef SEARCH_HIZ
layout(std430, binding = 6) readonly buffer Pyramid { vec2 pyramid[]; };
uniform int pyramid_offset[16];  // offset of level L (1..pyramid_top) within a map's block
uniform int pyramid_stride;      // cells of one map's levels
uniform int pyramid_top;         // the level with one cell
#endif

// u (segment fraction) where the projection crosses the texel line X (texel units) of
// axis a (0: x, 1: y); 2 when never. A solution with clip w <= 0 lies on the other
// branch of the projection (behind the light): the line is never reached.
float line_u(Segment s, int a, float X) {
    float ndc = 2.0 * X / float(light_res) - 1.0;
    float c = s.c0[a] - ndc * s.c0.w;
    float slope = (s.c1[a] - s.c0[a]) - ndc * (s.c1.w - s.c0.w);
    if (slope == 0.0) return 2.0;
    float u = -c / slope;
    return mix(s.c0.w, s.c1.w, u) > 0.0 ? u : 2.0;
}

// The texel under the segment at u, clamped into [lo, hi].
ivec2 texel_at(Segment s, float u, ivec2 lo, ivec2 hi) {
    vec4 clip = mix(s.c0, s.c1, u);
    vec2 texel = floor((clip.xy / clip.w * 0.5 + 0.5) * float(light_res));
    return clamp(ivec2(clamp(texel, vec2(-1.0), vec2(light_res))), lo, hi);
}

// The walk over one map: the texel it is in, where it entered, and the covered run.
struct Walk {
    ivec2 texel;         // level-0 texel
    ivec2 dir;           // direction of the projection per axis: -1, 0, +1
    float u;             // segment fraction where it entered
    bool run;            // the previous texel was covered ...
    bool positive;       // ... with f > 0 there
};

// The fraction where the walk leaves its cell of level L, and the axis it leaves by.
float cell_exit(Segment s, Walk w, int L, out int axis) {
    ivec2 cell = w.texel >> L;
    float ux = w.dir.x == 0 ? 2.0 : line_u(s, 0, float((w.dir.x > 0 ? cell.x + 1 : cell.x) << L));
    float uy = w.dir.y == 0 ? 2.0 : line_u(s, 1, float((w.dir.y > 0 ? cell.y + 1 : cell.y) << L));
    axis = ux <= uy ? 0 : 1;
    return max(min(min(ux, uy), 1.0), w.u);
}

// Move the walk past its cell of level L (left at u_out by axis); false when it left the map.
bool leave_cell(Segment s, inout Walk w, int L, float u_out, int axis) {
    ivec2 cell = w.texel >> L;
    ivec2 lo = cell << L, hi = min(((cell + 1) << L) - 1, ivec2(light_res - 1));
    ivec2 next = texel_at(s, u_out, lo, hi);  // along the edge: clamped into the cell
    if (axis == 0) next.x = w.dir.x > 0 ? hi.x + 1 : lo.x - 1;
    else next.y = w.dir.y > 0 ? hi.y + 1 : lo.y - 1;
    w.texel = next;
    w.u = u_out;
    return u_out < 1.0 && all(greaterThanEqual(next, ivec2(0))) && all(lessThan(next, ivec2(light_res)));
}

// The walk through one texel over [w.u, u_out]: the crossing's t, or -1 (and the run updated).
float texel_crossing(int map, Segment s, inout Walk w, float u_out, out int index) {
    index = (map * light_res + w.texel.y) * light_res + w.texel.x;
    ++g_map_reads;
    ++g_lookups;
    float D = map_dist[index];
    if (D <= 0.0) {
        w.run = false;
        return -1.0;
    }
    float ta = mix(s.t0, s.t1, w.u), tb = mix(s.t0, s.t1, u_out);
    float fa = length(s.q + s.d * ta) - D;
    bool entry_positive = fa > 0.0;
    // an edge of the map's surface: the sign differs from the covered texel before
    if (w.run && entry_positive != w.positive) return ta;
    // inside the texel: |q + d·t|² = D², the root on the far side of the entry's sign
    float qd = dot(s.q, s.d);
    float disc = qd * qd - (dot(s.q, s.q) - D * D);
    if (disc >= 0.0) {
        float root = entry_positive ? -qd - sqrt(disc) : -qd + sqrt(disc);
        if (root > ta && root <= tb) return root;
    }
    w.run = true;
    w.positive = entry_positive;
    return -1.0;
}

// After a crossing passed over: the run continues beyond it.
void continue_after(Segment s, inout Walk w, float u_out, int index) {
    w.run = true;
    w.positive = length(s.q + s.d * mix(s.t0, s.t1, u_out)) > map_dist[index];
}

#ifdef SEARCH_HIZ
// Can the walk skip the cell of level L over [w.u, u_out]? Updates the run when it can.
bool skip_cell(int map, Segment s, inout Walk w, int L, float u_out) {
    ivec2 cell = w.texel >> L;
    int n = ((light_res - 1) >> L) + 1;
    ++g_map_reads;
    ++g_lookups;
    vec2 range = pyramid[map * pyramid_stride + pyramid_offset[L] + cell.y * n + cell.x];
    if (range.y <= 0.0) {  // nothing covered: the run ends
        w.run = false;
        return true;
    }
    if (range.x < 0.0) return false;  // partly covered: where the run ends is in the texels
    float ta = mix(s.t0, s.t1, w.u), tb = mix(s.t0, s.t1, u_out);
    float r_min = length(s.q + s.d * clamp(-dot(s.q, s.d), ta, tb));
    float r_max = max(length(s.q + s.d * ta), length(s.q + s.d * tb));
    bool positive = r_min > range.y;
    if (!positive && !(r_max < range.x)) return false;  // the ranges meet: a crossing may lie here
    if (w.run && positive != w.positive) return false;  // the run's sign changes at the cell's first texel
    w.run = true;
    w.positive = positive;
    return true;
}
#endif

// First crossing on the map within [t0, t1]; returns t or -1, and the index of the map
// texel at t (the surface crossed). A crossing onto the start surface (start rule `id`
// or `facing`), or not at a surface (`crossing` = surface), is passed over.
float estimate_on_map(int map, Segment s, out int hit_index) {
    hit_index = -1;
    Walk w;
    // direction of the projection per axis: the sign of d(clip.a / clip.w)/du
    w.dir = ivec2(sign(s.c1.xy * s.c0.w - s.c0.xy * s.c1.w));
    w.u = 0.0;
    w.texel = texel_at(s, 0.0, ivec2(0), ivec2(light_res - 1));
    w.run = false;
    w.positive = false;
    int L = 0;
    for (int k = 0; k < 64 * light_res; ++k) {
        int axis;
        float u_out = cell_exit(s, w, L, axis);
#ifdef SEARCH_HIZ
        if (L > 0) {
            if (skip_cell(map, s, w, L, u_out)) {
                if (!leave_cell(s, w, L, u_out, axis)) break;
                L = min(L + 1, pyramid_top);
            } else {
                L -= 1;
            }
            continue;
        }
#endif
        int index;
        float t = texel_crossing(map, s, w, u_out, index);
        if (t >= 0.0) {
            if (!passed_over(index, s, t)) {
                hit_index = index;
                return t;
            }
            continue_after(s, w, u_out, index);
        }
        if (!leave_cell(s, w, 0, u_out, axis)) break;
#ifdef SEARCH_HIZ
        L = min(1, pyramid_top);
#endif
    }
    return -1.0;
}
