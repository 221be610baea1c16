// Camera G-buffer: what the primary ray through each pixel centre hits.
#include "common/model.glsl"

uniform mat4 view_proj;

in vec3 in_position;
in vec3 in_normal;
in float in_material;

out vec3 v_position;
out vec3 v_normal;

void main() {
    mat4 model = object_to_world(in_material);
    vec4 world = model * vec4(in_position, 1.0);
    v_position = world.xyz;
    v_normal = normalize(mat3(model) * in_normal);
    gl_Position = view_proj * world;
}
