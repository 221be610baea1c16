// beam_width = balanced, the balance map (approx.splat.Splatter.balance_map): per pixel of
// the pilot (splat/beam.frag.glsl with BEAM_PILOT: the step's beams at their differential
// widths on a coarser image, each half of them apart), the width factor s that minimises
// the pixel's expected squared error s⁴·b² + V/s (Kaplanyan & Dachsbacher 2013, "Adaptive
// progressive photon mapping": bias against variance per pixel):
// * the blur's bias grows with σ²: b = ½·σ²·ΔY, ΔY the Laplacian of the pilot's luminance,
//   σ² its beams' mean kernel variance (pixels²);
// * the noise of a sum of beams falls as 1/σ (each beam's share ∝ 1/σ, ∝ σ beams): V, the
//   frame's own, from its two interleaved halves: ¼·(Y₁ − Y₂)², averaged over 3×3 pixels
//   (the halves differ by the sampling's noise, random or stratified, and by the ripple of
//   kernels narrower than their beams' spacing).
// s = (V / 4b²)^(1/5), within [BALANCE_MIN, BALANCE_MAX]; b² less the noise the stencil
// itself reads (20·V·(σ²/2)²), so that noise is not taken for curvature. Written as ln s
// (0 where the pilot has no beam), read along each beam by splat/balance.glsl.
// Never wider than the differential width (BALANCE_MAX 1): a beam shades fragments in
// proportion to its width, so at equal cost a frame of wider beams has proportionally fewer
// of them and its noise V ∝ 1/(beams·σ) stays what it was, while the blur grows; narrower
// beams buy photons with the fragments they save (docs/decisions.md "Beam widths from the
// frame": with BALANCE_MAX 4 the cost match took 51 → 40 photons a side on sphere1).
// Control: BALANCE_MIRRORED takes the curvature of the mirrored pixel (a wrong curvature).
#ifndef BALANCE_MIN
#define BALANCE_MIN 0.125
#endif
#ifndef BALANCE_MAX
#define BALANCE_MAX 1.0
#endif
uniform sampler2D pilot;  // Y of one half, Y of the other, ΣY·σ², 0 per pilot pixel (RGBA32F)
out vec4 color;

vec4 pilot_at(ivec2 p) {
    return texelFetch(pilot, clamp(p, ivec2(0), textureSize(pilot, 0) - 1), 0);
}
float luminance(ivec2 p) {
    vec4 c = pilot_at(p);
    return c.r + c.g;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(pilot, p, 0);
    float y = c.r + c.g;
    if (!(y > 0.0)) {
        color = vec4(0.0);
        return;
    }
    float variance = 0.0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            vec4 n = pilot_at(p + ivec2(dx, dy));
            variance += 0.25 * (n.r - n.g) * (n.r - n.g) / 9.0;
        }
    float width2 = c.b / y;
#ifdef BALANCE_MIRRORED
    ivec2 q = textureSize(pilot, 0) - 1 - p;
#else
    ivec2 q = p;
#endif
    float laplacian = luminance(q + ivec2(1, 0)) + luminance(q - ivec2(1, 0)) + luminance(q + ivec2(0, 1))
                      + luminance(q - ivec2(0, 1)) - 4.0 * luminance(q);
    float bias = 0.5 * width2 * laplacian;
    float bias2 = max(bias * bias - 5.0 * width2 * width2 * variance, 0.0);
    float factor = bias2 > 0.0 ? pow(variance / (4.0 * bias2), 0.2) : BALANCE_MAX;
    color = vec4(log(clamp(factor, BALANCE_MIN, BALANCE_MAX)), 0.0, 0.0, 0.0);
}
