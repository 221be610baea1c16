// Truncation of the splat kernel, shared by both splat stages.
#ifndef VOLCAUSTICS_KERNEL_GLSL
#define VOLCAUSTICS_KERNEL_GLSL
const float TRUNCATION = 3.0;                 // kernel support radius in σ
const float KEPT_MASS = 0.9888910034617577;   // 1 − exp(−TRUNCATION²/2): 2-D Gaussian mass within it
#endif
