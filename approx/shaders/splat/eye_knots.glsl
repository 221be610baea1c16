// Knots along each pixel's ray for beams' exact depth to the eye under the decomposition's
// control EXACT_EYE: `eye_knot_count` distances evenly spaced from the eye up to `eye_reach`
// (the density grid's farthest corner), where splat/eye_knots.comp.glsl integrates ρ exactly
// once per pixel and the fragment stage (beam.frag.glsl) goes on from the knot before its
// point. Both compute a knot's distance, and its place in the buffer, with these expressions.
#ifndef VOLCAUSTICS_EYE_KNOTS_GLSL
#define VOLCAUSTICS_EYE_KNOTS_GLSL

#ifndef EYE_KNOTS_BINDING
#define EYE_KNOTS_BINDING 13
#endif

uniform int eye_knot_count;   // knots per pixel (≥ 1; the first at the eye)
uniform float eye_reach;      // the last knot's distance and beyond (m)

// The distance of knot j (0 … eye_knot_count − 1) from the eye.
float eye_knot(int j) {
    return eye_reach * float(j) / float(eye_knot_count);
}

// The last knot at or before distance t along a pixel's ray.
int eye_knot_before(float t) {
    int j = clamp(int(floor(t * float(eye_knot_count) / eye_reach)), 0, eye_knot_count - 1);
    while (j > 0 && eye_knot(j) > t) --j;  // rounding: the knot's own expression decides
    return j;
}

// Where pixel (x, y) keeps knot j in the buffer of a viewport `size` pixels.
int eye_knot_slot(ivec2 pixel, int j, ivec2 size) {
    return (j * size.y + pixel.y) * size.x + pixel.x;
}

#endif
