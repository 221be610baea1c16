// The eye knots of beams' exact depth to the eye (splat/eye_knots.glsl; the decomposition's
// control EXACT_EYE): for every pixel of the view, the exact optical depth ∫ρ ds from the eye
// along the ray through its centre (splat/pixel_ray.glsl) to each knot, summed knot to knot
// (common/density.glsl's exact_depth: Simpson's rule between the planes through the cell
// centres, exact for the trilinear ρ). No display frame makes them.
#include "common/density.glsl"
#include "splat/pixel_ray.glsl"
#include "splat/eye_knots.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = EYE_KNOTS_BINDING) writeonly buffer EyeKnots { float eye_knots[]; };

uniform mat4 view_proj;
uniform vec2 viewport;        // the view's size (pixels)
uniform vec3 eye;

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy), size = ivec2(viewport);
    if (any(greaterThanEqual(pixel, size))) return;
    vec3 ray = pixel_ray_through(vec2(pixel) + 0.5, viewport, view_proj);
    float depth = 0.0;
    eye_knots[eye_knot_slot(pixel, 0, size)] = 0.0;
    for (int j = 1; j < eye_knot_count; ++j) {
        float from = eye_knot(j - 1);
        depth += exact_depth(eye + ray * from, ray, eye_knot(j) - from);
        eye_knots[eye_knot_slot(pixel, j, size)] = depth;
    }
}
