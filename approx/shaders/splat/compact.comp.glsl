// Gather one step's medium collisions (SPLAT_BEAMS: its segments in the medium, each a
// beam) from the per-photon records into a compact splat list, in photon order, so that
// additive blending sums them in the same order on every run (bit-identical images for a
// seed). Three dispatches, the counts never leaving the GPU:
//   PASS_COUNT: per block of BLOCK photons, the number of collisions;
//   PASS_SCAN:  one work group turns the block counts into offsets (exclusive prefix sum)
//               and writes the total into the splat pass's indirect draw commands;
//   (write):    each collision goes to block_offset[block] + its rank in the block
//               (exclusive prefix sum in shared memory).
#include "common/photon.glsl"

#define BLOCK 256
layout(local_size_x = BLOCK) in;

layout(std430, binding = 1) buffer BlockCounts { uint block_value[]; };  // counts, then offsets
#ifdef PASS_SCAN
// DrawArraysIndirectCommand rows, 5 uints apart (moderngl's render_indirect stride): the
// splats' quads (4 vertices, one instance a splat), then their points (the density pre-pass)
layout(std430, binding = 2) writeonly buffer Commands { uint commands[10]; };
uniform uint block_count;
shared uint partial[BLOCK];

void main() {
    uint lane = gl_LocalInvocationID.x;
    uint per = (block_count + uint(BLOCK) - 1u) / uint(BLOCK);  // blocks a lane sums, in order
    uint begin = min(lane * per, block_count), end = min(begin + per, block_count);
    uint own = 0u;
    for (uint b = begin; b < end; ++b) own += block_value[b];
    partial[lane] = own;
    barrier();
    for (uint offset = 1u; offset < uint(BLOCK); offset <<= 1) {  // Hillis–Steele, inclusive
        uint add = lane >= offset ? partial[lane - offset] : 0u;
        barrier();
        partial[lane] += add;
        barrier();
    }
    uint running = partial[lane] - own;  // exclusive: the splats of every block before begin
    for (uint b = begin; b < end; ++b) {
        uint n = block_value[b];
        block_value[b] = running;
        running += n;
    }
    if (lane == uint(BLOCK) - 1u) {
        uint total = partial[lane];
        commands[0] = 4u; commands[1] = total; commands[2] = 0u; commands[3] = 0u; commands[4] = 0u;
        commands[5] = 1u; commands[6] = total; commands[7] = 0u; commands[8] = 0u; commands[9] = 0u;
    }
}
#else
layout(std430, binding = 0) readonly buffer Records { Record records[]; };
#ifdef SPLAT_BEAMS
layout(std430, binding = 2) writeonly buffer Beams { Beam beams[]; };
#else
layout(std430, binding = 2) writeonly buffer Splats { Splat splats[]; };
#endif
uniform uint photon_count;
uniform uint step_index;   // the step's (1-based), for common/split.glsl
uniform uint batch_slots;  // photon_res²: the slots of one batch
#include "common/split.glsl"
#if defined(SPLAT_ADAPTIVE) || defined(BEAM_DIFFERENTIAL)
// SPLAT_ADAPTIVE: the kernel of a collision is splat_footprints × the photon's footprint
// there (its ray differential, trace.comp.glsl), within [splat_radius / 16, 4 · splat_radius].
// BEAM_DIFFERENTIAL: a beam's kernel is splat_footprints × the footprint w + r·s at s along
// it, (w, r) the differential at its start; the row carries σ0 = |a| (a = splat_footprints·w,
// at least BEAM_SIGMA_FLOOR so that it counts as the beam's own) and the rate sign(a)·
// splat_footprints·r, so that |σ0 + rate·s| = |a + b·s|; the splatter clamps it
// (splat/beam.vert.glsl). Numpy twin: approx.splat.beam_kernels.
#ifdef BEAM_BALANCED
// beam_width = balanced: the second compaction of a step scales each beam's differential
// (its footprint and rate, in place: what the measured frame reads) by the balance the
// frame's pilot found along it (splat/balance.glsl)
layout(std430, binding = 3) buffer Differentials { vec2 differentials[]; };  // (footprint, rate)
#include "splat/balance.glsl"
#else
layout(std430, binding = 3) readonly buffer Differentials { vec2 differentials[]; };  // (footprint, rate)
#endif
uniform float splat_radius;
uniform float splat_footprints;
#endif
#ifndef BEAM_SIGMA_FLOOR
#define BEAM_SIGMA_FLOOR 1e-20
#endif

shared uint rank[BLOCK];

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint lane = gl_LocalInvocationID.x;
#ifdef SPLAT_BEAMS
    // a segment that ran in the medium (inside -1 at its start) and ended at a surface or
    // the medium's end; a photon lost or dead draws none
    int status = i < photon_count ? int(records[i].end_status.w + 0.5) : STATUS_DEAD;
    bool kept = (status == STATUS_SURFACE || status == STATUS_LEFT_SCENE) && records[i].power_inside.w < 0.0;
#else
    bool kept = i < photon_count && int(records[i].end_status.w + 0.5) == STATUS_COLLIDED;
#endif
    kept = kept && !split_silent(i, step_index);  // a split batch's share of another's segments (fresnel_splits)
    rank[lane] = kept ? 1u : 0u;
    barrier();
    // Hillis–Steele inclusive scan over the block.
    for (uint offset = 1u; offset < uint(BLOCK); offset <<= 1) {
        uint add = lane >= offset ? rank[lane - offset] : 0u;
        barrier();
        rank[lane] += add;
        barrier();
    }
#ifdef PASS_COUNT
    if (lane == uint(BLOCK) - 1u) block_value[gl_WorkGroupID.x] = rank[lane];
#else
    if (kept) {
        Record r = records[i];
        uint slot = block_value[gl_WorkGroupID.x] + rank[lane] - 1u;
#ifdef SPLAT_ADAPTIVE
        float sigma = clamp(splat_footprints * abs(differentials[i].x), splat_radius / 16.0, 4.0 * splat_radius);
        float rate = 0.0;
#elif defined(BEAM_DIFFERENTIAL)
#ifdef BEAM_BALANCED
        if (balance_apply != 0u) {
            float len = status == STATUS_SURFACE ? r.dir_t.w : r.extra.z;
            differentials[i] *= beam_balance(r.start_maxlen.xyz, r.dir_t.xyz, len);
        }
#endif
        float a = splat_footprints * differentials[i].x;
        float sigma = max(abs(a), BEAM_SIGMA_FLOOR);
        float rate = (a < 0.0 ? -splat_footprints : splat_footprints) * differentials[i].y;
#else
        float sigma = 0.0;  // the uniform splat_radius
        float rate = 0.0;
#endif
#ifdef SPLAT_BEAMS
        float len = status == STATUS_SURFACE ? r.dir_t.w : r.extra.z;  // to the hit, or the searched span
        beams[slot] = Beam(vec4(r.start_maxlen.xyz, len), vec4(r.dir_t.xyz, sigma), vec4(r.power_start.rgb, rate));
#else
        splats[slot] = Splat(vec4(r.end_status.xyz, float(STATUS_COLLIDED)), vec4(r.dir_t.xyz, sigma),
                             vec4(r.power_inside.rgb, 0.0));
#endif
    }
#endif
}
#endif
