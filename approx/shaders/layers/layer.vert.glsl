// Light layers (paper Fig. 1A, 3): geometry seen from the spot light.
#include "common/model.glsl"

uniform mat4 light_view_proj;

in vec3 in_position;
in vec3 in_normal;
in vec3 in_face_normal;
in float in_material;

out vec3 v_position;
out vec3 v_normal;
flat out vec3 v_face_normal;
flat out float v_material;

void main() {
    mat4 model = object_to_world(in_material);
    vec4 world = model * vec4(in_position, 1.0);
    v_position = world.xyz;
    v_normal = normalize(mat3(model) * in_normal);
    v_face_normal = normalize(mat3(model) * in_face_normal);
    v_material = in_material;
    gl_Position = light_view_proj * world;
}
