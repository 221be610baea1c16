// Single-precision arc cosine after the CEPHES asinf/acosf approximation (the
// same polynomial Dr.Jit uses, so the spot falloff matches Mitsuba's to float
// rounding). GLSL's built-in acos is far less accurate on some drivers
// (llvmpipe: 7e-5 rad), which shows up as a visible bias in the falloff ramp.
#ifndef VOLCAUSTICS_ACOS_GLSL
#define VOLCAUSTICS_ACOS_GLSL

float acos_accurate(float x) {
    float xa = abs(x);
    bool big = xa > 0.5;
    float x1 = 0.5 * (1.0 - xa);
    float x3 = big ? x1 : x * x;
    float x4 = big ? sqrt(x1) : xa;
    float p = (((4.2163199048e-2 * x3 + 2.4181311049e-2) * x3 + 4.5470025998e-2) * x3 + 7.4953002686e-2) * x3
              + 1.6666752422e-1;
    float z1 = p * (x3 * x4) + x4;
    if (big) {
        float z2 = z1 + z1;
        return x < 0.0 ? 3.14159265358979 - z2 : z2;
    }
    return 1.5707963267949 - (x < 0.0 ? -z1 : z1);
}

#endif
