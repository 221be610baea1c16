// A heterogeneous medium's density ρ(x) (scenes/density.py states the grid's one
// convention: values[k][j][i] at the centre of cell (i, j, k) of the box, trilinear between
// centres, clamped beyond the outermost, 0 outside the box), read from a storage buffer with
// the interpolation written out, so that the exact replay's numpy twin
// (scenes.density.DensityGrid.eval) computes the same numbers; and the photons' free flights
// by delta tracking through the coarse grid of majorants (scenes.density.DensityGrid.majorants):
// regular tracking (one unit exponential spent cell by cell at each cell's majorant), each
// tentative collision real with probability ρ(x)·sigma_bar / μ(cell) (Novák et al. 2018 §5).
// Tentative collision k takes dims TRACKING_DIM + 2k (its distance) and TRACKING_DIM + 2k + 1
// (real or not) of u(seed, photon, step, ·): the exact replay draws the same numbers.
#ifndef VOLCAUSTICS_DENSITY_GLSL
#define VOLCAUSTICS_DENSITY_GLSL

#ifndef DENSITY_BINDING
#define DENSITY_BINDING 11
#endif
#ifndef MAJORANT_BINDING
#define MAJORANT_BINDING 12
#endif
#ifndef TRACKING_DIM
#define TRACKING_DIM 8u            // scenes.rng.TRACKING_DIM
#endif
#ifndef MAX_TENTATIVE
#define MAX_TENTATIVE 4096u        // scenes.rng.MAX_TENTATIVE: a flight stops (no collision) after so many
#endif

layout(std430, binding = DENSITY_BINDING) readonly buffer DensityValues { float density_values[]; };
uniform ivec3 density_res;     // cells along x, y, z
uniform vec3 density_min;      // the grid's box (m)
uniform vec3 density_max;

float density_value(ivec3 c) {
    return density_values[(c.z * density_res.y + c.y) * density_res.x + c.x];
}

// ρ at p: trilinear between cell centres, 0 outside the grid's box.
float density_at(vec3 p) {
    vec3 f = (p - density_min) / (density_max - density_min);
    if (any(lessThan(f, vec3(0.0))) || any(greaterThan(f, vec3(1.0)))) return 0.0;
    vec3 u = f * vec3(density_res) - 0.5;
    vec3 base = floor(u);
    vec3 w = u - base;
    ivec3 i0 = ivec3(base);
    ivec3 top = density_res - 1;
    ivec3 a = clamp(i0, ivec3(0), top), b = clamp(i0 + 1, ivec3(0), top);
    float c00 = mix(density_value(ivec3(a.x, a.y, a.z)), density_value(ivec3(b.x, a.y, a.z)), w.x);
    float c10 = mix(density_value(ivec3(a.x, b.y, a.z)), density_value(ivec3(b.x, b.y, a.z)), w.x);
    float c01 = mix(density_value(ivec3(a.x, a.y, b.z)), density_value(ivec3(b.x, a.y, b.z)), w.x);
    float c11 = mix(density_value(ivec3(a.x, b.y, b.z)), density_value(ivec3(b.x, b.y, b.z)), w.x);
    return mix(mix(c00, c10, w.y), mix(c01, c11, w.y), w.z);
}

// ∫ρ ds over o + s·d, s in [0, len]: `steps` midpoint samples (a fixed march).
float march_depth(vec3 o, vec3 d, float len, int steps) {
    float h = len / float(steps);
    float sum = 0.0;
    for (int k = 0; k < steps; ++k) sum += density_at(o + d * (h * (float(k) + 0.5)));
    return sum * h;
}

// ∫ρ ds over o + s·d (d unit), s in [0, len], exact but for float32 rounding: along a line the
// trilinear ρ is a cubic between the planes through the cell centres, so Simpson's rule on each
// piece between them is exact (scenes.tracking.optical_depth, its float64 twin). The decomposition's
// transmittance terms take it in place of the march and the camera volume (controls EXACT_MARCH,
// EXACT_EYE); no display frame reads it.
float exact_depth(vec3 o, vec3 d, float len) {
    vec3 inv = 1.0 / d;
    vec3 ta = (density_min - o) * inv, tb = (density_max - o) * inv;
    vec3 t_lo = min(ta, tb), t_hi = max(ta, tb);
    float t = max(max(max(t_lo.x, t_lo.y), t_lo.z), 0.0);
    float t_end = min(min(min(t_hi.x, t_hi.y), t_hi.z), len);
    if (!(t < t_end)) return 0.0;
    vec3 h = (density_max - density_min) / vec3(density_res);
    bvec3 moving = notEqual(d, vec3(0.0));
    // the first plane through cell centres beyond the entry, along each axis
    vec3 u = (o + d * t - density_min) / h - 0.5;
    vec3 next = mix(ceil(u - 1.0), floor(u + 1.0), greaterThan(d, vec3(0.0)));
    vec3 t_next = mix(vec3(1e30), (density_min + (next + 0.5) * h - o) * inv, moving);
    vec3 t_step = mix(vec3(1e30), abs(h * inv), moving);
    vec3 lo = density_min, hi = density_max;
    float f0 = density_at(clamp(o + d * t, lo, hi));
    float depth = 0.0;
    int pieces = density_res.x + density_res.y + density_res.z + 4;  // planes crossed, at most
    for (int k = 0; k < pieces && t < t_end; ++k) {
        float t1 = min(min(min(t_next.x, t_next.y), t_next.z), t_end);
        if (t1 > t) {
            float f1 = density_at(clamp(o + d * t1, lo, hi));
            depth += (t1 - t) / 6.0 * (f0 + 4.0 * density_at(clamp(o + d * (0.5 * (t + t1)), lo, hi)) + f1);
            f0 = f1;
            t = t1;
        }
        t_next += mix(vec3(0.0), t_step, lessThanEqual(t_next, vec3(t1)));
    }
    return depth;
}

#ifdef DELTA_TRACKING
#include "common/rng.glsl"
layout(std430, binding = MAJORANT_BINDING) readonly buffer MajorantValues { float majorant_values[]; };
uniform ivec3 majorant_res;    // coarse cells along x, y, z
uniform int majorant_block;    // grid cells per coarse cell along each axis

// The first real collision on o + t·d, t in [0, t_max), at rate ρ(x)·rate, or -1 for none;
// `tentative` counts the tentative collisions drawn (the loop's work).
float delta_track(vec3 o, vec3 d, float t_max, float rate, uint seed, uint photon, uint flight_step,
                  out uint tentative) {
    tentative = 0u;
    // the part of the ray inside the grid's box: outside it ρ = 0 and nothing collides
    vec3 inv = 1.0 / d;
    vec3 ta = (density_min - o) * inv, tb = (density_max - o) * inv;
    vec3 t_lo = min(ta, tb), t_hi = max(ta, tb);
    float t = max(max(max(t_lo.x, t_lo.y), t_lo.z), 0.0);
    float t_end = min(min(min(t_hi.x, t_hi.y), t_hi.z), t_max);
    if (!(t < t_end) || rate <= 0.0) return -1.0;
    vec3 cell_size = (density_max - density_min) / vec3(density_res) * float(majorant_block);
    vec3 start = (o + d * t - density_min) / cell_size;
    ivec3 cell = clamp(ivec3(floor(start)), ivec3(0), majorant_res - 1);
    ivec3 stride = ivec3(sign(d));
    vec3 next_plane = density_min + (vec3(cell) + step(vec3(0.0), d)) * cell_size;
    vec3 t_next = mix(vec3(1e30), (next_plane - o) * inv, notEqual(d, vec3(0.0)));
    vec3 t_step = mix(vec3(1e30), abs(cell_size * inv), notEqual(d, vec3(0.0)));
    float budget = -log(1.0 - rng_uniform(seed, photon, flight_step, TRACKING_DIM));  // unit exponential left
    while (t < t_end && tentative < MAX_TENTATIVE) {
        float t_exit = min(min(min(t_next.x, t_next.y), t_next.z), t_end);
        float mu = majorant_values[(cell.z * majorant_res.y + cell.y) * majorant_res.x + cell.x] * rate;
#ifdef MAJORANT_SCALE  // a control: majorants scaled (below 1: below the density, a wrong tracker)
        mu *= float(MAJORANT_SCALE);
#endif
#ifdef GRID_IGNORED    // a control: the grid ignored, every tentative collision real at the mean rate
        mu = rate;
#endif
        if (mu * (t_exit - t) > budget) {  // a tentative collision in this cell
            t += budget / mu;
            uint k = tentative++;
#ifdef GRID_IGNORED
            float rho = 1.0;
#else
            float rho = density_at(o + d * t);
#endif
            if (rng_uniform(seed, photon, flight_step, TRACKING_DIM + 2u * k + 1u) * mu < rho * rate) return t;
            budget = -log(1.0 - rng_uniform(seed, photon, flight_step, TRACKING_DIM + 2u * tentative));
            continue;
        }
        budget -= mu * (t_exit - t);
        t = t_exit;
        if (t_next.x <= t_next.y && t_next.x <= t_next.z) { cell.x += stride.x; t_next.x += t_step.x; }
        else if (t_next.y <= t_next.z) { cell.y += stride.y; t_next.y += t_step.y; }
        else { cell.z += stride.z; t_next.z += t_step.z; }
        if (any(lessThan(cell, ivec3(0))) || any(greaterThanEqual(cell, majorant_res))) break;
    }
    return -1.0;
}
#endif

#endif
