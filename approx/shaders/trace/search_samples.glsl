// The sampled searches of one map (part of trace/trace.comp.glsl): `bisection`
// (paper §4.1) and `secant`. PEAK_SAMPLES interior samples, uniform along the
// segment's projection in the light's image, look for the first sign change of
// f = (distance to the light) − (map distance) between covered samples; where the
// map's coverage ends or begins between two samples (a silhouette), the covered end
// at the edge is found by binary search and tested too. ITERATIONS steps then refine
// the crossing: halving the bracket (`bisection`), or regula falsi with the Illinois
// rule, which keeps a bracket (`secant`: Umenhoffer, Patow & Szirmay-Kalos, GPU Gems 3
// ch. 17; the secant refinement of Bevy's raymarch.wgsl). f jumps at texel edges, so
// a secant step that leaves the bracket's interior falls back to its midpoint.


// Segment parameter for a fraction lam of the segment's projection in the light
// image (perspective-correct: clip w is linear in t, screen position is not).
float screen_uniform_t(float lam, Segment s) {
    float mu = (lam / s.c1.w) / ((1.0 - lam) / s.c0.w + lam / s.c1.w);
    return mix(s.t0, s.t1, mu);
}

// Binary search between a covered and an uncovered point of the map for where its
// coverage ends; returns the covered end.
float coverage_edge(int map, Segment s, float covered, float uncovered) {
    for (int k = 0; k < ITERATIONS; ++k) {
        float mid = 0.5 * (covered + uncovered);
        // At float precision the bracket no longer changes (a covered point never moves
        // the uncovered end, nor the reverse): the remaining steps would repeat this one.
        if (mid == covered || mid == uncovered) break;
        bool v;
        segment_f(map, s, mid, v);
        if (v) covered = mid; else uncovered = mid;
    }
    return covered;
}

// Can f change sign on [a, b]? Not when the segment's distance to the light there stays
// below the nearest or above the farthest surface of the map (then f keeps one sign at
// every covered point): a coverage edge there needs no search.
bool may_cross(int map, Segment s, float a, float b) {
    float r_min = length(s.q + s.d * clamp(-dot(s.q, s.d), a, b));
    float r_max = max(length(s.q + s.d * a), length(s.q + s.d * b));
    return r_max >= map_min_dist[map] && r_min <= map_max_dist[map];
}

#ifdef SEARCH_SECANT
// Regula falsi (Illinois) for the crossing in [a, b] (f changes sign: fa on a's side,
// fb beyond); returns t and the map texel beyond the crossing (the surface crossed).
float refine_crossing(int map, Segment s, float a, float b, float fa, float fb, out int index) {
    int side = 0;  // the end the last step replaced: -1 b, +1 a (Illinois: the other's f is halved)
    for (int k = 0; k < ITERATIONS; ++k) {
        float t = b - fb * (b - a) / (fb - fa);
        if (!(t > a && t < b)) break;  // on an end of the bracket: converged to rounding
        bool v;
        float ft = segment_f(map, s, t, v);
        // An uncovered point counts as the start's side: the crossing is beyond it.
        if (v && ((ft > 0.0) != (fa > 0.0))) {
            b = t;
            fb = ft;
            if (side == -1) fa *= 0.5;
            side = -1;
        } else {
            a = t;
            if (v) fa = ft;
            if (side == 1) fb *= 0.5;
            side = 1;
        }
    }
    float t = clamp(b - fb * (b - a) / (fb - fa), a, b);
    // The texel beyond the crossing: at the last estimate when it lies beyond, else at b.
    bool v;
    float ft = segment_f(map, s, t, v, index);
    if (!(v && ((ft > 0.0) == (fb > 0.0)))) index = segment_texel_index(map, s, b);
    return t;
}
#else
// Binary search for the crossing in [a, b] (f changes sign between them, a's side
// given by fa); returns t and the map texel beyond the crossing (the surface crossed).
float refine_crossing(int map, Segment s, float a, float b, float fa, float fb, out int index) {
    bool a_positive = fa > 0.0;
    for (int k = 0; k < ITERATIONS; ++k) {
        float mid = 0.5 * (a + b);
        // At float precision the bracket no longer changes (a's side never moves b, b's
        // side never moves a): the remaining steps would repeat this one.
        if (mid == a || mid == b) break;
        bool v;
        float fm = segment_f(map, s, mid, v);
        // An uncovered midpoint counts as the start's side: the crossing is beyond it.
        if (v && ((fm > 0.0) != a_positive)) b = mid; else a = mid;
    }
    index = segment_texel_index(map, s, b);
    return 0.5 * (a + b);
}
#endif

// First sign change on the map within [t0, t1]; returns t or -1, and the index of the
// map texel at t (the surface crossed). A crossing counts between two covered points.
// Where the map's coverage begins or ends between two samples (a silhouette seen from
// the light: photons inside glass often leave next to one), the covered end nearest
// the edge is found by binary search and tested too, so a crossing between the last
// covered sample and the edge is not missed. A crossing onto the start surface (start
// rule `id`) is passed over.
float estimate_on_map(int map, Segment s, out int hit_index) {
    hit_index = -1;
    bool prev_valid;
    float prev_t = s.t0;
    float prev_f = segment_f(map, s, s.t0, prev_valid);
    for (int j = 1; j <= PEAK_SAMPLES + 1; ++j) {
        float t = j == PEAK_SAMPLES + 1 ? s.t1 : screen_uniform_t(float(j) / float(PEAK_SAMPLES + 1), s);
        bool valid;
        float f = segment_f(map, s, t, valid);
        // The bracket to refine, if any: one refinement call site per sample step (lanes
        // run in step on SIMD hardware: every call site costs all of them its loop).
        bool bracket = false;
        float a = prev_t, b = t, fa = prev_f, fb = f;
        if (valid && prev_valid) {
            bracket = (f > 0.0) != (prev_f > 0.0);
        } else if ((valid || prev_valid) && may_cross(map, s, prev_t, t)) {
            float edge = coverage_edge(map, s, prev_valid ? prev_t : t, prev_valid ? t : prev_t);
            bool v;
            float f_edge = segment_f(map, s, edge, v);
            if (prev_valid && (f_edge > 0.0) != (prev_f > 0.0)) {
                bracket = true;
                b = edge;
                fb = f_edge;
            } else if (valid && (f_edge > 0.0) != (f > 0.0)) {
                bracket = true;
                a = edge;
                fa = f_edge;
            }
        }
        float found = bracket ? refine_crossing(map, s, a, b, fa, fb, hit_index) : -1.0;
        if (found >= 0.0 && !is_start_surface(hit_index)) return found;
        prev_t = t;
        prev_f = f;
        prev_valid = valid;
    }
    hit_index = -1;
    return -1.0;
}
