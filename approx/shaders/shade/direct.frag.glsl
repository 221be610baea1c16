// Direct lighting on diffuse (Lambertian) surfaces seen by the camera: spot light
// with shadow map, attenuated by the medium on the light path and to the eye:
//   L = albedo/π · I·falloff(ω)/r² · cos θ · V · exp(-σt (r + s))
// (HETEROGENEOUS: exp(−σt·∫ρ) of both legs from the transmittance volumes, common/volumes.glsl).
#include "common/camera.glsl"
#include "common/spot.glsl"
#include "common/shadow.glsl"
#include "common/kinds.glsl"
#ifdef HETEROGENEOUS  // both legs' transmittance from the transmittance volumes
#include "common/volumes.glsl"
#endif

uniform sampler2D gbuffer_geometry;  // (distance to eye, KIND_*, material, 0)
uniform sampler2D gbuffer_normal;
uniform vec3 albedo[MAX_DIFFUSE];
uniform vec3 sigma_t;
uniform float texel_angle;           // shadow-map texel footprint per metre

out vec4 out_color;

void main() {
    vec4 g = texelFetch(gbuffer_geometry, ivec2(gl_FragCoord.xy), 0);
    vec3 radiance = vec3(0.0);
    if (gbuffer_kind(g) == KIND_DIFFUSE) {
        vec3 r = pixel_ray(gl_FragCoord.xy);
        vec3 x = eye + r * g.x;
        vec3 n = texelFetch(gbuffer_normal, ivec2(gl_FragCoord.xy), 0).xyz;
        if (dot(n, r) > 0.0) n = -n;  // two-sided: the side facing the camera
        vec3 to_light = light_position - x;
        float dist = length(to_light);
        vec3 l = to_light / dist;
        float cos_theta = dot(n, l);
        if (cos_theta > 0.0) {
            float bias = 2.0 * texel_angle * dist / max(cos_theta, 0.1);
            float vis = light_visibility(x, dist, bias);
            radiance = albedo[int(g.z + 0.5)] / 3.141592653589793 * light_intensity * spot_falloff(-l)
                     * cos_theta / (dist * dist) * vis
#ifdef HETEROGENEOUS
                     * exp(-sigma_t * (light_depth(x) + camera_depth(x)));
#else
                     * exp(-sigma_t * (dist + g.x));
#endif
        }
    }
    out_color = vec4(radiance, 1.0);
}
