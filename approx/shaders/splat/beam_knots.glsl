// Knots along a beam for its exact depth under the decomposition's control EXACT_MARCH:
// BEAM_KNOTS points evenly spaced from its start, where the vertex stage (beam.vert.glsl)
// integrates ρ exactly once per beam and the fragment stage (beam.frag.glsl) goes on from
// the knot before its point. Both stages compute a knot's distance with the same expression.
#ifndef VOLCAUSTICS_BEAM_KNOTS_GLSL
#define VOLCAUSTICS_BEAM_KNOTS_GLSL

#ifndef BEAM_KNOTS
#define BEAM_KNOTS 8
#endif

// The distance of knot j (0 … BEAM_KNOTS − 1) from the start of a beam of length len.
float beam_knot(float len, int j) {
    return len * float(j) / float(BEAM_KNOTS);
}

// The last knot at or before distance s along a beam of length len.
int beam_knot_before(float len, float s) {
    int j = clamp(int(floor(s * float(BEAM_KNOTS) / len)), 0, BEAM_KNOTS - 1);
    while (j > 0 && beam_knot(len, j) > s) --j;  // rounding: the knot's own expression decides
    return j;
}

#endif
