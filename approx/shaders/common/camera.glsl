// Camera rays for full-screen and splat passes: the world direction through a
// pixel centre from gl_FragCoord (GL rows bottom-up; the host flips on read-back).
#ifndef VOLCAUSTICS_CAMERA_GLSL
#define VOLCAUSTICS_CAMERA_GLSL

uniform vec3 eye;
uniform mat4 inv_view_proj;
uniform vec2 viewport;

vec3 pixel_ray(vec2 frag_coord) {
    vec2 ndc = frag_coord / viewport * 2.0 - 1.0;
    vec4 far_point = inv_view_proj * vec4(ndc, 1.0, 1.0);
    return normalize(far_point.xyz / far_point.w - eye);
}

#endif
