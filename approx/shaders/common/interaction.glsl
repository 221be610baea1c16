// The specular interaction at a surface hit (paper §4.3): Snell refraction or
// reflection, Fresnel weighting (deterministic: refracted power × (1 - R), total
// internal reflection keeps the power; FRESNEL_STOCHASTIC: reflect with
// probability R, power unchanged; FRESNEL_STRATIFIED: the choices' numbers stratified
// over the photons, scenes/rng.py). Numpy twin: reference/oracle.py. Requires
// common/optics.glsl, common/rng.glsl and the uniform array `ior` (defined by the
// including shader). A number xi below 0 or above 1 is a split's forced choice
// (common/split.glsl): reflection at R of the power, refraction at 1 − R, whatever the mode.
#ifndef VOLCAUSTICS_INTERACTION_GLSL
#define VOLCAUSTICS_INTERACTION_GLSL

#include "common/photon.glsl"
#include "common/rng.glsl"

#ifndef FRESNEL_DIM
#define FRESNEL_DIM 1u  // scenes.rng.FRESNEL_DIM
#endif

// The number photon `photon` compares with R at step `step` (scenes.rng.fresnel_uniform).
float fresnel_uniform(uint seed, uint photon, uint step) {
#ifdef FRESNEL_STRATIFIED
    return stratified_uniform(seed, photon, step, FRESNEL_DIM);
#else
    return rng_uniform(seed, photon, step, FRESNEL_DIM);
#endif
}

// The Fresnel reflectance R for the incoming unit direction d at a surface of hit_material
// whose outward shading normal is n: the side it arrives from, hence eta, read from n.
float fresnel_at(vec3 d, vec3 n, int hit_material) {
    bool from_outside = dot(d, n) <= 0.0;
    float eta = from_outside ? ior[hit_material] : 1.0 / ior[hit_material];
    return fresnel_dielectric(-dot(d, from_outside ? n : -n), eta);
}

// d: incoming unit direction; n: the hit's outward shading normal; n_geometric: the
// outward geometric normal of its triangle; inside: set to the material the photon
// travels in afterwards (-1 medium); hit_material: object whose surface was hit. As Mitsuba's dielectric
// BSDF: the side the photon arrives from, hence eta, is read from the shading
// normal, and Fresnel, refraction and reflection use it. Inside or outside
// afterwards follows the one rule of docs/conventions.md: a direction below the geometric
// surface (dot with the outward geometric normal < 0) is inside the object hit.
// Updates d, power, inside; returns FLAG_* bits.
uint surface_interaction(inout vec3 d, inout vec3 power, out int inside, vec3 n, vec3 n_geometric,
                         int hit_material, float xi) {
    float R = fresnel_at(d, n, hit_material);
    bool from_outside = dot(d, n) <= 0.0;
    if (!from_outside) n = -n;  // shading normal on the incident side
    float eta = from_outside ? ior[hit_material] : 1.0 / ior[hit_material];
    vec3 t;
    uint flags = 0u;
    if (!refract_dir(d, n, eta, t)) {
        d = reflect_dir(d, n);
        flags = FLAG_REFLECTED | FLAG_TIR;
        if (xi > 1.0) power = vec3(0.0);  // a split's forced refraction: none under TIR
    } else if (xi < 0.0) {  // a split's forced reflection (common/split.glsl), at R of the power
        power *= R;
        d = reflect_dir(d, n);
        flags = FLAG_REFLECTED;
    } else if (xi > 1.0) {  // its forced refraction, at 1 − R
        power *= (1.0 - R);
        d = t;
    } else {
#ifdef FRESNEL_STOCHASTIC
        if (xi < R) {
            d = reflect_dir(d, n);
            flags = FLAG_REFLECTED;
        } else {
            d = t;
        }
#else
        power *= (1.0 - R);
        d = t;
#endif
    }
    inside = dot(d, n_geometric) < 0.0 ? hit_material : -1;
    return flags;
}

#endif
