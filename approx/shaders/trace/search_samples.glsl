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
        int index = segment_texel_index(map, s, mid);
        if (index >= 0 && map_distance_at(index) > 0.0) covered = mid; else uncovered = mid;
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

// Segment parameter of sample k of a scan (0: the segment's start, PEAK_SAMPLES + 1 its end).
float sample_t(int k, Segment s) {
    if (k == 0) return s.t0;
    return k == PEAK_SAMPLES + 1 ? s.t1 : screen_uniform_t(float(k) / float(PEAK_SAMPLES + 1), s);
}

// First sign change on the map within [t0, t1]; returns t or -1, and the index of the
// map texel at t (the surface crossed). A crossing counts between two covered points.
// Where the map's coverage begins or ends between two samples (a silhouette seen from
// the light: photons inside glass often leave next to one), the covered end nearest
// the edge is found by binary search and tested too, so a crossing between the last
// covered sample and the edge is not missed. A crossing onto the start surface (start
// rule `id` or `facing`), or not at a surface (`crossing` = surface), is passed over.
//
// The work is ordered for SIMD hardware, where lanes run in step and a loop inside a
// branch costs every lane its trip count as soon as one lane enters it: a scan reads the
// samples up to the first sign change, noting the first coverage edge before it; one
// edge search and one refinement follow, outside the sample loop, so lanes whose edges
// and crossings lie at different samples search together. The result is that of testing
// the sample steps in order: a scan that finds nothing to return (its edge held no
// crossing and another edge follows; the crossing was passed over) is resumed
// from the sample step it tested last.
float estimate_on_map(int map, Segment s, out int hit_index) {
    hit_index = -1;
    int j = 0;  // the sample the scan starts from
    bool prev_valid;
    float prev_t = s.t0;
    float prev_f = segment_f(map, s, s.t0, prev_valid);
    while (true) {
        // sample steps k = j+1, ... ([t(k−1), t(k)]) up to the first sign change between
        // covered samples (its bracket a, b); the first coverage edge's step on the way
        int k_bracket = 0, k_edge = 0;
        bool more_edges = false;
        float a, b, fa, fb;
        float edge_a, edge_b, edge_f;  // the edge's step and its covered end's f
        bool edge_at_a;                // ... covered at its start
        for (int k = j + 1; k <= PEAK_SAMPLES + 1; ++k) {
            float t = sample_t(k, s);
            bool valid;
            float f = segment_f(map, s, t, valid);
            if (valid && prev_valid) {
                if ((f > 0.0) != (prev_f > 0.0)) {
                    k_bracket = k;
                    a = prev_t; b = t; fa = prev_f; fb = f;
                    break;
                }
            } else if ((valid || prev_valid) && may_cross(map, s, prev_t, t)) {
                more_edges = k_edge > 0;
                if (k_edge == 0) {
                    k_edge = k;
                    edge_a = prev_t; edge_b = t; edge_at_a = prev_valid;
                    edge_f = prev_valid ? prev_f : f;
                }
            }
            prev_t = t;
            prev_f = f;
            prev_valid = valid;
        }
        // the edge: a sign change between its covered end and where coverage ends?
        bool edge_bracket = false;
        if (k_edge > 0) {
            float edge = coverage_edge(map, s, edge_at_a ? edge_a : edge_b, edge_at_a ? edge_b : edge_a);
            bool v;
            float f_edge = segment_f(map, s, edge, v);
            edge_bracket = (f_edge > 0.0) != (edge_f > 0.0);
            if (edge_bracket) {
                a = edge_at_a ? edge_a : edge;
                b = edge_at_a ? edge : edge_b;
                fa = edge_at_a ? edge_f : f_edge;
                fb = edge_at_a ? f_edge : edge_f;
            }
        }
        int k_resume = edge_bracket || more_edges ? k_edge : k_bracket;
        if (k_resume == 0) break;
        if (edge_bracket || !more_edges) {
            float found = refine_crossing(map, s, a, b, fa, fb, hit_index);
            if (!passed_over(hit_index, s, found)) return found;
        }
        j = k_resume;
        prev_t = sample_t(j, s);
        prev_f = segment_f(map, s, prev_t, prev_valid);
    }
    hit_index = -1;
    return -1.0;
}
