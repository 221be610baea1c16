// Mitsuba 3 `spot` falloff, reproduced (src/emitters/spot.cpp, falloff_curve):
// 1 inside beam_width, linear in angle down to 0 at cutoff_angle, 0 beyond.
// The constants are computed on the CPU in float32 exactly as Mitsuba does
// (approx/light.py: spot_constants) and passed as uniforms.
#ifndef VOLCAUSTICS_SPOT_GLSL
#define VOLCAUSTICS_SPOT_GLSL

#include "common/acos.glsl"

uniform vec3 light_position;
uniform vec3 light_direction;       // unit spot axis
uniform vec3 light_intensity;       // W/sr on the axis
uniform float spot_cutoff_angle;    // radians (float32 of Mitsuba's deg_to_rad)
uniform float spot_cos_cutoff;      // cos(cutoff_angle)
uniform float spot_cos_beam;        // cos(beam_width)
uniform float spot_inv_transition;  // 1 / (cutoff_angle - beam_width); 0 when they are equal

// Falloff for a unit direction `d` leaving the light (world space).
float spot_falloff(vec3 d) {
    float cos_theta = dot(d, light_direction);
    float beam_res = cos_theta >= spot_cos_beam
        ? 1.0
        : (spot_cutoff_angle - acos_accurate(clamp(cos_theta, -1.0, 1.0))) * spot_inv_transition;
    return cos_theta > spot_cos_cutoff ? beam_res : 0.0;
}

#endif
