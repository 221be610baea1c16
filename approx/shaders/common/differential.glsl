// Photon differentials (Igehy 1999, "Tracing ray differentials"; Schjøth et al. 2007,
// "Photon differentials"), scalar and isotropic: a photon carries its footprint w,
// the signed distance from its ray to its neighbours' rays where it is (m), and w's
// rate of change along the ray s (m/m). Free flight: w += s·t. A specular interaction
// keeps w and changes s by the surface's curvature κ along it (1/m, > 0 where the
// surface is convex towards the incoming photon), as Coddington's equations do for a
// thin pencil of rays:
//   s' = μ·s + (μ·cos θi − cos θt)·κ·w,   μ = n_incident / n_transmitted,
// reflection being μ = 1, cos θt = −cos θi. A parallel pencil (s = 0) entering a sphere
// of radius R (κ = 1/R) at normal incidence gets s' = −(1 − 1/n)·w/R: it focuses at
// n·R/(n − 1), the refracting surface's focal length. The width change by cos θt/cos θi
// in the plane of incidence is left out (isotropic).
#ifndef VOLCAUSTICS_DIFFERENTIAL_GLSL
#define VOLCAUSTICS_DIFFERENTIAL_GLSL

#include "common/photon.glsl"

// The rate s after an interaction: d_in, d_out unit directions before and after, n the
// shading normal on the incident side (dot(d_in, n) < 0), mu = n_incident / n_transmitted
// (ignored for a reflection), kappa the curvature on the incident side, w the footprint.
float differential_rate(float s, float w, vec3 d_in, vec3 d_out, vec3 n, float mu, float kappa, bool reflected) {
    float cos_i = -dot(d_in, n);
    if (reflected) return s + 2.0 * cos_i * kappa * w;
    float cos_t = -dot(d_out, n);
    return mu * s + (mu * cos_i - cos_t) * kappa * w;
}

// Curvature along the surface between two points p0, p1 with outward normals n0, n1
// (dn·dp / |dp|²: 1/R on a sphere of radius R, 0 on a plane), or 0 when they are the
// same point.
float curvature_between(vec3 p0, vec3 n0, vec3 p1, vec3 n1) {
    vec3 dp = p1 - p0;
    float len2 = dot(dp, dp);
    return len2 > 0.0 ? dot(n1 - n0, dp) / len2 : 0.0;
}

// The rate after surface_interaction (common/interaction.glsl) turned d_in into d_out
// at a surface of `material` with outward shading normal n and outward curvature kappa,
// returning `flags`: the incident side and the relative index as that function finds
// them. Needs the uniform array `ior`.
float interaction_rate(float s, float w, vec3 d_in, vec3 d_out, vec3 n, float kappa, int material, uint flags) {
#ifdef DIFFERENTIAL_UNPROPAGATED
    return s;  // a negative control (tests only): the rate kept through every interaction
#endif
    bool from_outside = dot(d_in, n) <= 0.0;
    float mu = from_outside ? 1.0 / ior[material] : ior[material];
    return differential_rate(s, w, d_in, d_out, from_outside ? n : -n, mu, from_outside ? kappa : -kappa,
                             (flags & FLAG_REFLECTED) != 0u);
}

#endif
