// Scene preview: world-space triangles with flat normals, projected by the camera.
uniform mat4 view_proj;

in vec3 in_position;
in vec3 in_normal;

out vec3 v_position;
out vec3 v_normal;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
