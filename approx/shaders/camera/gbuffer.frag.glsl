// Outputs: (distance to the eye, kind, material index, 0) and (world normal, 0).
// kind: KIND_DIFFUSE or KIND_SPECULAR (common/kinds.glsl), a uniform per draw;
// the target is cleared to 0 = KIND_NONE where nothing is drawn.
uniform vec3 eye;
uniform float kind;
uniform float material;

in vec3 v_position;
in vec3 v_normal;

layout(location = 0) out vec4 out_geometry;
layout(location = 1) out vec4 out_normal;

void main() {
    out_geometry = vec4(length(v_position - eye), kind, material, 0.0);
    out_normal = vec4(normalize(v_normal), 0.0);
}
