// Phase functions (per steradian). PHASE_G is defined by the loader for
// Henyey–Greenstein media; without it the phase is isotropic 1/(4π).
#ifndef VOLCAUSTICS_PHASE_GLSL
#define VOLCAUSTICS_PHASE_GLSL

const float INV_FOUR_PI = 0.07957747154594767;

// cos_theta: cosine between the propagation direction before scattering and after.
float phase_eval(float cos_theta) {
#ifdef PHASE_G
    float g = PHASE_G;
    float denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return INV_FOUR_PI * (1.0 - g * g) / (denom * sqrt(denom));
#else
    return INV_FOUR_PI;
#endif
}

#endif
