// The specular interaction at a surface hit (paper §4.3): Snell refraction or
// reflection, Fresnel weighting (deterministic: refracted power × (1 - R), total
// internal reflection keeps the power; FRESNEL_STOCHASTIC: reflect with
// probability R, power unchanged). Requires common/optics.glsl, common/rng.glsl
// and the uniform array `ior` (defined by the including shader).
#ifndef VOLCAUSTICS_INTERACTION_GLSL
#define VOLCAUSTICS_INTERACTION_GLSL

#include "common/photon.glsl"

// d: incoming unit direction; n: surface normal (any side); inside: material the
// photon travels in (-1 medium); hit_material: object whose surface was hit.
// Updates d, power, inside; returns FLAG_* bits.
uint surface_interaction(inout vec3 d, inout vec3 power, inout int inside, vec3 n, int hit_material, float xi) {
    if (dot(d, n) > 0.0) n = -n;  // normal on the incident side
    bool entering = inside < 0;
    int m = entering ? hit_material : inside;
    float eta = entering ? ior[m] : 1.0 / ior[m];
    float cos_i = -dot(d, n);
    float R = fresnel_dielectric(cos_i, eta);
    vec3 t;
    bool can_refract = refract_dir(d, n, eta, t);
    if (!can_refract) {
        d = reflect_dir(d, n);
        return FLAG_REFLECTED | FLAG_TIR;
    }
#ifdef FRESNEL_STOCHASTIC
    if (xi < R) {
        d = reflect_dir(d, n);
        return FLAG_REFLECTED;
    }
#else
    power *= (1.0 - R);
#endif
    d = t;
    inside = entering ? m : -1;
    return 0u;
}

#endif
