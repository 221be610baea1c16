// Error function, Abramowitz & Stegun 7.1.26 (|error| <= 1.5e-7).
#ifndef VOLCAUSTICS_ERF_GLSL
#define VOLCAUSTICS_ERF_GLSL

float erf_approx(float x) {
    float s = sign(x);
    x = abs(x);
    float t = 1.0 / (1.0 + 0.3275911 * x);
    float y = 1.0 - (((((1.061405429 * t - 1.453152027) * t) + 1.421413741) * t - 0.284496736) * t + 0.254829592) * t * exp(-x * x);
    return s * y;
}

#endif
