// Truncation of the splat kernel, shared by both splat stages.
#ifndef VOLCAUSTICS_KERNEL_GLSL
#define VOLCAUSTICS_KERNEL_GLSL
const float TRUNCATION = 3.0;                 // kernel support radius in σ
const float KEPT_MASS = 0.9888910034617577;   // 1 − exp(−TRUNCATION²/2): 2-D Gaussian mass within it
// Pixel-integrated kernels (adaptive and density splats) are cut to the square of
// half-side TRUNCATION·σ around their centre, per axis, and divided by the mass it keeps.
const float AXIS_KEPT_MASS = 0.9973002039367398;  // erf(TRUNCATION/√2): 1-D Gaussian mass within ±TRUNCATION·σ
#endif
