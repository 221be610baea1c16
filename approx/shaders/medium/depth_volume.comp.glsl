// A transmittance volume: the optical depth of ρ, ∫ρ ds, from a point (the spot light, or
// the eye) along the ray through each texel of its view, at SLICES distances; a renderer's
// light-space transmittance map or camera froxel volume (Hillaire 2015, "Physically based
// and unified volumetric rendering in Frostbite"). Texel (i, j, k) holds the depth from
// `origin` along the ray through the view's texel centre (i, j) up to distance
// k·max_distance / (slices − 1), summed slice by slice from one midpoint sample of ρ each:
// the slices' count sets the march's error, the columns' count the error across rays.
// Its readers take exp(−σt·depth) by linear interpolation (common/volumes.glsl).
#include "common/density.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = 0) writeonly uniform image3D depth_volume;
uniform vec3 origin;           // the light's position or the eye (m)
uniform mat4 inv_view_proj;    // the view whose texels the columns go through
uniform ivec2 columns;         // texels of the view along x and y
uniform float max_distance;    // the last slice's distance from origin (m)
uniform int slices;            // distances per column (≥ 2)

void main() {
    ivec2 ij = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(ij, columns))) return;
    vec2 ndc = (vec2(ij) + 0.5) / vec2(columns) * 2.0 - 1.0;
    vec4 far = inv_view_proj * vec4(ndc, 0.5, 1.0);
    vec3 d = normalize(far.xyz / far.w - origin);
    float h = max_distance / float(slices - 1);
    float depth = 0.0;
    imageStore(depth_volume, ivec3(ij, 0), vec4(0.0));
    for (int k = 1; k < slices; ++k) {
        depth += density_at(origin + d * (h * (float(k) - 0.5))) * h;
        imageStore(depth_volume, ivec3(ij, k), vec4(depth));
    }
}
