// Octahedral unit-vector encoding (Cigolle et al., "A Survey of Efficient
// Representations for Independent Unit Vectors", JCGT 3(2), 2014).
#ifndef VOLCAUSTICS_OCTAHEDRAL_GLSL
#define VOLCAUSTICS_OCTAHEDRAL_GLSL

vec2 octa_sign(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

vec2 octa_encode(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return n.z <= 0.0 ? (1.0 - abs(p.yx)) * octa_sign(p) : p;
}

vec3 octa_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * octa_sign(n.xy);
    return normalize(n);
}

#endif
