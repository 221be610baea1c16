// Light layers (paper Fig. 1A, 3): geometry seen from the spot light.
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
    v_position = in_position;
    v_normal = in_normal;
    v_face_normal = in_face_normal;
    v_material = in_material;
    gl_Position = light_view_proj * vec4(in_position, 1.0);
}
