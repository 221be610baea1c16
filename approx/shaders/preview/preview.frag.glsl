// Scene preview (not physically based): Lambert from the spot light inside its
// cutoff cone (inverse-square, unshadowed) plus a dim camera headlight, so that
// geometry, framing and the light cone can be checked at a glance.
uniform vec3 eye;
uniform vec3 light_position;
uniform vec3 light_direction;
uniform float cos_cutoff;
uniform vec3 intensity;
uniform vec3 albedo;
uniform float headlight;

in vec3 v_position;
in vec3 v_normal;

out vec4 frag_color;

void main() {
    vec3 n = normalize(v_normal);
    vec3 to_eye = normalize(eye - v_position);
    if (dot(n, to_eye) < 0.0) n = -n;  // two-sided
    vec3 to_light = light_position - v_position;
    float dist2 = dot(to_light, to_light);
    to_light *= inversesqrt(dist2);
    float inside = dot(-to_light, light_direction) > cos_cutoff ? 1.0 : 0.0;
    vec3 lit = intensity * inside * max(dot(n, to_light), 0.0) / dist2;
    vec3 radiance = albedo / 3.14159265 * (lit + headlight * max(dot(n, to_eye), 0.0));
    frag_color = vec4(radiance, 1.0);
}
