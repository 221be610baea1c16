// Where a segment's projection in the light image crosses texel lines (part of
// trace/trace.comp.glsl; used by the texel walks, trace/search_texels.glsl). The projection's crossing of a line x = X solves an affine equation in the
// segment's clip coordinates (McGuire & Mara, JCGT 2014, step in screen space so).

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

