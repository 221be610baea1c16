// Camera G-buffer: what the primary ray through each pixel centre hits.
uniform mat4 view_proj;

in vec3 in_position;
in vec3 in_normal;
in float in_material;

out vec3 v_position;
out vec3 v_normal;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
