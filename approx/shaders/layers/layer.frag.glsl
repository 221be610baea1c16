// One light map: per texel the nearest surface that passes this map's filter.
// Outputs: location 0 (RGBA32F) distance to the light (not z), material id,
// octahedral world shading normal; cleared to 0 = no surface. Location 1 (attached
// only where needed) the octahedral outward geometric normal of the triangle, which
// decides inside/outside after a specular interaction (docs/conventions.md), and the triangle's
// primitive id + 1 (one draw holds every specular object, so the id names one triangle
// of the scene): the start rule `id` ignores crossings onto the triangle a segment
// leaves. Its target is RGBA32F under that rule and RG32F otherwise (the id dropped).
//
// Filters (uniforms):
//   facing        +1 front faces only, -1 back faces only, 0 both
//   threshold     keep fragments whose distance along the spot axis exceeds it
//                 (strategy `threshold`, paper §4.2); -inf to disable
//   use_previous  depth peeling (strategy `peel`): keep fragments farther than
//                 the previous map of the same facing by more than peel_epsilon
#include "common/octahedral.glsl"

uniform vec3 light_position;
uniform vec3 light_direction;
uniform int facing;
uniform float threshold;
uniform bool use_previous;
uniform sampler2D previous_map;
uniform float peel_epsilon;

in vec3 v_position;
in vec3 v_normal;
flat in vec3 v_face_normal;
flat in float v_material;

layout(location = 0) out vec4 out_map;
layout(location = 1) out vec4 out_geometric;

void main() {
    if (facing > 0 && !gl_FrontFacing) discard;
    if (facing < 0 && gl_FrontFacing) discard;
    vec3 to_point = v_position - light_position;
    if (dot(to_point, light_direction) <= threshold) discard;
    float dist = length(to_point);
    if (use_previous) {
        float prev = texelFetch(previous_map, ivec2(gl_FragCoord.xy), 0).r;
        if (prev <= 0.0 || dist <= prev + peel_epsilon) discard;
    }
    out_map = vec4(dist, v_material, octa_encode(normalize(v_normal)));
    out_geometric = vec4(octa_encode(normalize(v_face_normal)), float(gl_PrimitiveID + 1), 0.0);
}
