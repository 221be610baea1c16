// Reading the transmittance volumes (medium/depth_volume.comp.glsl): the optical depth of ρ
// from the spot light (light_depth) or from the eye (camera_depth) to a point, by linear
// interpolation between the volume's columns and slices; the medium's transmittance there
// is exp(−sigma_t · depth). Outside a view the depth is clamped to its edge.
#ifndef VOLCAUSTICS_VOLUMES_GLSL
#define VOLCAUSTICS_VOLUMES_GLSL

uniform sampler3D light_volume;
uniform mat4 light_volume_view_proj;
uniform vec3 light_volume_origin;
uniform float light_volume_distance;
uniform int light_slices;
uniform sampler3D camera_volume;
uniform mat4 camera_volume_view_proj;
uniform vec3 camera_volume_origin;
uniform float camera_volume_distance;
uniform int camera_slices;

float volume_depth(sampler3D volume, mat4 view_proj, vec3 origin, float max_distance, int slices, vec3 p) {
    vec4 clip = view_proj * vec4(p, 1.0);
    vec2 uv = clip.xy / max(clip.w, 1e-9) * 0.5 + 0.5;
    float k = clamp(distance(p, origin) / max_distance, 0.0, 1.0) * float(slices - 1);
    return texture(volume, vec3(uv, (k + 0.5) / float(slices))).r;
}

float light_depth(vec3 p) {
    return volume_depth(light_volume, light_volume_view_proj, light_volume_origin, light_volume_distance,
                        light_slices, p);
}

float camera_depth(vec3 p) {
    return volume_depth(camera_volume, camera_volume_view_proj, camera_volume_origin, camera_volume_distance,
                        camera_slices, p);
}

#endif
