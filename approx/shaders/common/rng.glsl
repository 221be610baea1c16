// Shared counter-based random numbers u(seed, photon, step, dim).
// Twin of scenes/rng.py (the specification lives there); must agree bit for bit.
// PCG hash: Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3), 2020.
#ifndef VOLCAUSTICS_RNG_GLSL
#define VOLCAUSTICS_RNG_GLSL

#ifndef GOLDEN
#define GOLDEN 0x9E3779B9u           // scenes.rng.GOLDEN
#endif
#ifndef ROTATION_PHOTON
#define ROTATION_PHOTON 0xFFFFFFFFu  // scenes.rng.ROTATION_PHOTON
#endif

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

uint hash4(uint seed, uint photon, uint step, uint dim) {
    uint h = pcg_hash(seed);
    h = pcg_hash(h + photon);
    h = pcg_hash(h + step);
    return pcg_hash(h + dim);
}

// Uniform in [0, 1) on a 2^-24 grid: exactly representable, identical to numpy.
float rng_uniform(uint seed, uint photon, uint step, uint dim) {
    return float(hash4(seed, photon, step, dim) >> 8u) * (1.0 / 16777216.0);
}

// The stratified number of scenes/rng.py: the golden-ratio Weyl sequence over the photon
// index, rotated by the hash of (seed, 2^32 - 1, step, dim).
float stratified_uniform(uint seed, uint photon, uint step, uint dim) {
    uint h = hash4(seed, ROTATION_PHOTON, step, dim) + photon * GOLDEN;
    return float(h >> 8u) * (1.0 / 16777216.0);
}

#endif
