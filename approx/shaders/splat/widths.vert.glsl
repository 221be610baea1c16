// splat = density, the widths pass: the kernel σ the splat pass would give each splat
// (splat.vert.glsl) from a density pre-pass of any photons, written out by transform
// feedback instead of drawn. The decomposition splats every image of a seed with the
// widths of that seed's real frame (experiment/kernels.py).
#include "common/photon.glsl"
#include "splat/density_width.glsl"

uniform mat4 view_proj;
uniform vec3 eye;
uniform float splat_radius;
uniform float pixel_angle;    // 2·tan(fov_y/2)/height: a pixel's width per metre of distance
uniform vec2 viewport;        // image size (pixels)

in vec4 in_end;               // per splat: record.end_status

out float out_sigma;          // the splat's kernel standard deviation (m); 0 for a row that draws nothing

void main() {
    if (int(in_end.w + 0.5) != STATUS_COLLIDED) {
        out_sigma = 0.0;
        return;
    }
    vec3 c = in_end.xyz;
    float dist = length(eye - c);
    vec4 centre_clip = view_proj * vec4(c, 1.0);
    vec2 center_px = (centre_clip.xy / centre_clip.w * 0.5 + 0.5) * viewport;
    out_sigma = density_sigma(center_px, viewport, dist, pixel_angle, splat_radius);
}
