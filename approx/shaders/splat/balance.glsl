// beam_width = balanced: the factor a beam's differential width is scaled by, read from
// the frame's balance map (splat/balance.frag.glsl: per pixel of the pilot, the natural
// log of the width factor that balances the kernel's blur against its noise there), at
// BALANCE_SAMPLES points spread along the beam that the camera sees: exp of their mean
// (a geometric mean: halving and doubling cancel); 1 where none is in view.
#ifndef VOLCAUSTICS_BALANCE_GLSL
#define VOLCAUSTICS_BALANCE_GLSL
#ifndef BALANCE_SAMPLES
#define BALANCE_SAMPLES 4
#endif
uniform sampler2D balance_map;  // R32F, the pilot's size, bilinear: ln(width factor)
uniform mat4 view_proj;
uniform uint balance_apply;     // 0: the pilot's compaction (widths as they are), 1: scaled

float beam_balance(vec3 start, vec3 dir, float len) {
    float sum = 0.0, n = 0.0;
    for (int k = 0; k < BALANCE_SAMPLES; ++k) {
        vec4 c = view_proj * vec4(start + dir * (len * (float(k) + 0.5) / float(BALANCE_SAMPLES)), 1.0);
        if (!(c.w > 1e-6)) continue;
        vec2 uv = c.xy / c.w * 0.5 + 0.5;
        if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) continue;
        sum += textureLod(balance_map, uv, 0.0).r;
        n += 1.0;
    }
    return n > 0.0 ? exp(sum / n) : 1.0;
}
#endif
