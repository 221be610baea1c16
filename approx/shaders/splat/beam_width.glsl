// A beam's kernel σ at s metres along it, shared by both beam stages. A row that carries
// its own σ (Beam.dir.w > 0) has σ0 there at its start, changing at Beam.power.w per
// metre (beam_width = differential: the photon's ray-differential footprint times
// splat_footprints, splat/compact.comp.glsl; 0 for the decomposition's small kernel),
// held within [radius/16, 4·radius] as adaptive splats are; else every beam's σ is the
// uniform splat_radius.
#ifndef VOLCAUSTICS_BEAM_WIDTH_GLSL
#define VOLCAUSTICS_BEAM_WIDTH_GLSL
// The row's own σ held above its floor only: a convex function of s, so the chord between
// two points bounds it between them (splat/beam.vert.glsl draws trapezoids with it).
float beam_sigma_floored(float sigma0, float rate, float s, float radius) {
    return max(abs(sigma0 + rate * s), radius / 16.0);
}
float beam_sigma(float sigma0, float rate, float s, float radius) {
    if (!(sigma0 > 0.0)) return radius;
    return min(beam_sigma_floored(sigma0, rate, s, radius), 4.0 * radius);
}
#endif
