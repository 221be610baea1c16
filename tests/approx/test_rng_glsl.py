"""The GLSL twin of the shared RNG (and of its stratified numbers) is bit-identical to numpy on
100,000 tuples."""

from __future__ import annotations

import numpy as np

from volcaustics.approx.glsl import build_source
from volcaustics.scenes.rng import hash4, stratified, uniform

# Test fixture shader (inline by design): one invocation per (seed, photon, step, dim) tuple.
RNG_CHECK = """
#include "common/rng.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Tuples { uvec4 tuples[]; };
layout(std430, binding = 1) writeonly buffer Hashes { uint hashes[]; };
layout(std430, binding = 2) writeonly buffer Uniforms { float uniforms[]; };
layout(std430, binding = 3) writeonly buffer Stratified { float stratified[]; };
uniform uint count;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    uvec4 t = tuples[i];
    hashes[i] = hash4(t.x, t.y, t.z, t.w);
    uniforms[i] = rng_uniform(t.x, t.y, t.z, t.w);
    stratified[i] = stratified_uniform(t.x, t.y, t.z, t.w);
}
"""


def test_glsl_rng_bit_identical_to_numpy(ctx):
    n = 100_000
    rng = np.random.default_rng(2024)
    tuples = rng.integers(0, 2**32, size=(n, 4), dtype=np.uint64).astype(np.uint32)
    tuples[:1000, 1] = np.arange(1000)  # also small consecutive counters, as the tracer uses
    tuples[:1000, 2:] = [3, 5]
    tuples[1000:1004] = [[0, 0, 0, 0], [2**32 - 1] * 4, [1, 2, 3, 4], [0, 2**32 - 1, 0, 2**32 - 1]]

    shader = ctx.compute_shader(build_source(RNG_CHECK))
    src = ctx.buffer(tuples.tobytes())
    out_h, out_u, out_s = ctx.buffer(reserve=4 * n), ctx.buffer(reserve=4 * n), ctx.buffer(reserve=4 * n)
    src.bind_to_storage_buffer(0)
    out_h.bind_to_storage_buffer(1)
    out_u.bind_to_storage_buffer(2)
    out_s.bind_to_storage_buffer(3)
    shader["count"].value = n
    shader.run(group_x=(n + 63) // 64)
    gl_hash = np.frombuffer(out_h.read(), dtype=np.uint32)
    gl_u = np.frombuffer(out_u.read(), dtype=np.float32)
    gl_s = np.frombuffer(out_s.read(), dtype=np.float32)
    for r in (src, out_h, out_u, out_s, shader):
        r.release()

    cols = [tuples[:, k] for k in range(4)]
    np_hash, np_u = hash4(*cols), uniform(*cols)
    assert np.array_equal(gl_hash, np_hash), f"{np.count_nonzero(gl_hash != np_hash)} hashes differ"
    assert np.array_equal(gl_u.view(np.uint32), np_u.view(np.uint32)), "floats differ bit-wise"
    np_s = stratified(*cols)
    assert np.array_equal(gl_s.view(np.uint32), np_s.view(np.uint32)), "stratified floats differ bit-wise"
