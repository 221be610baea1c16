// Owen-scrambled Sobol points in the unit square: twin of scenes/sobol.py (the
// specification lives there); must agree bit for bit.
// Scramble: Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020.
#ifndef VOLCAUSTICS_SOBOL_GLSL
#define VOLCAUSTICS_SOBOL_GLSL
#include "common/rng.glsl"

uint sobol_scramble(uint x, uint s) {
    x = bitfieldReverse(x);
    x += s;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return bitfieldReverse(x);
}

uint sobol_dim1(uint index) {
    uint x = 0u;
    uint v = 0x80000000u;
    for (int bit = 0; bit < 32; ++bit) {
        if (((index >> uint(bit)) & 1u) != 0u) x ^= v;
        v ^= v >> 1u;
    }
    return x;
}

vec2 sobol_2d(uint seed, uint index) {
    uint x0 = sobol_scramble(bitfieldReverse(index), pcg_hash(seed + 1u));
    uint x1 = sobol_scramble(sobol_dim1(index), pcg_hash(seed + 2u));
    return vec2(float(x0 >> 8u), float(x1 >> 8u)) * (1.0 / 16777216.0);
}

uint spread_bits(uint v) {
    v &= 0xFFFFu;
    v = (v | (v << 8u)) & 0x00FF00FFu;
    v = (v | (v << 4u)) & 0x0F0F0F0Fu;
    v = (v | (v << 2u)) & 0x33333333u;
    return (v | (v << 1u)) & 0x55555555u;
}

uint morton(ivec2 texel) { return spread_bits(uint(texel.x)) | (spread_bits(uint(texel.y)) << 1u); }

#endif
