// Visibility of the spot light from a point, from the light's nearest-surface
// map of all objects (R: distance to the light, 0 = nothing).
#ifndef VOLCAUSTICS_SHADOW_GLSL
#define VOLCAUSTICS_SHADOW_GLSL

uniform sampler2D shadow_map;
uniform mat4 light_view_proj;
uniform int light_res;   // the shadow map is light_res² (the parameter)

// 1 if nothing lies between the light and p (with `bias` metres of tolerance).
float light_visibility(vec3 p, float dist_to_light, float bias) {
    vec4 clip = light_view_proj * vec4(p, 1.0);
    if (clip.w <= 0.0) return 0.0;
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) return 0.0;
    float occluder = texelFetch(shadow_map, ivec2(uv * float(light_res)), 0).r;
    return (occluder <= 0.0 || dist_to_light <= occluder + bias) ? 1.0 : 0.0;
}

#endif
