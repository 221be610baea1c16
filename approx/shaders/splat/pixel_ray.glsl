// The camera ray through a pixel's centre (unit, world space), the image-plane point
// (x/P00, y/P11) at NDC (x, y), along view_proj's rows (row 0 = P00·right, row 1 = P11·up,
// row 3 = forward). `pixel`: the centre in window coordinates (gl_FragCoord.xy, i + 0.5);
// the beams' fragment stage and their eye knots (splat/eye_knots.comp.glsl) take the same ray.
#ifndef VOLCAUSTICS_PIXEL_RAY_GLSL
#define VOLCAUSTICS_PIXEL_RAY_GLSL

vec3 pixel_ray_through(vec2 pixel, vec2 viewport, mat4 view_proj) {
    vec2 ndc = pixel / viewport * 2.0 - 1.0;
    vec3 right = vec3(view_proj[0][0], view_proj[1][0], view_proj[2][0]);
    vec3 up = vec3(view_proj[0][1], view_proj[1][1], view_proj[2][1]);
    vec3 forward = vec3(view_proj[0][3], view_proj[1][3], view_proj[2][3]);
    return normalize(forward + ndc.x / dot(right, right) * right + ndc.y / dot(up, up) * up);
}

#endif
