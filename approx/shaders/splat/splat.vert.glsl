// Photon splatting (paper §3, Eq. 5, §4.3): every photon whose step ended at a
// medium collision is a normalised 3D Gaussian (standard deviation SIGMA) drawn as
// a billboard perpendicular to the ray towards it, wide enough to cover the
// Gaussian's 3σ sphere in perspective (the fragment shader renormalises the
// truncated kernel so that its integral stays exact). The per-photon weight is
// Φ·(σs/sigma_bar)·p(θ)·τ(eye, x): power, scattering per collision, phase towards
// the camera, transmittance to the eye (evaluated at the photon centre; HETEROGENEOUS: from
// the camera's transmittance volume, or exact under the decomposition's control EXACT_EYE). In a heterogeneous medium collisions come at rate
// ρ(x)·sigma_bar and scatter ρ(x)·σs: the weight σs/sigma_bar is the same.
#include "common/phase.glsl"
#include "common/photon.glsl"
#include "splat/kernel.glsl"
#ifdef HETEROGENEOUS  // τ(eye, x) from the camera's transmittance volume (common/volumes.glsl)
#include "common/volumes.glsl"
#ifdef EXACT_EYE
#include "common/density.glsl"
#endif
#endif

uniform mat4 view_proj;
uniform vec3 eye;
uniform vec3 scatter_weight;  // sigma_s / sigma_bar (RGB)
uniform vec3 sigma_t;
uniform float splat_radius;   // kernel standard deviation (m), unless the splat carries its own
uniform float pixel_angle;    // 2·tan(fov_y/2)/height: a pixel's width per metre of distance
uniform vec2 viewport;        // image size (pixels)

in vec2 in_corner;            // per vertex: (±1, ±1)
in vec4 in_dir_t;             // per instance: record.dir_t
in vec4 in_end;               // per instance: record.end_status
in vec4 in_power;             // per instance: record.power_inside

out vec3 v_center;
out vec3 v_corner;            // world position on the billboard: the pixel ray passes through it
flat out vec3 v_weight;
#ifdef SPLAT_DENSITY
#include "splat/density_width.glsl"
#endif
#ifdef SPLAT_ADAPTIVE
flat out float v_sigma;       // this splat's kernel standard deviation (m)
flat out float v_pixel;       // a pixel's width at the splat (m), the kernel integrated over it; 0: splat_radius
flat out vec2 v_center_px;    // the splat centre's window coordinates (pixels)
#endif

void main() {
    if (int(in_end.w + 0.5) != STATUS_COLLIDED) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: no fragments
        v_center = vec3(0.0);
        v_corner = vec3(0.0);
        v_weight = vec3(0.0);
#ifdef SPLAT_ADAPTIVE
        v_sigma = splat_radius;
        v_pixel = 0.0;
        v_center_px = vec2(0.0);
#endif
        return;
    }
    vec3 c = in_end.xyz;
    vec3 to_eye = eye - c;
    float dist = length(to_eye);
    vec3 w = to_eye / dist;
#if defined(HETEROGENEOUS) && defined(EXACT_EYE)
    v_weight = in_power.rgb * scatter_weight * phase_eval(dot(in_dir_t.xyz, w)) * exp(-sigma_t * exact_depth(eye, -w, dist));
#elif defined(HETEROGENEOUS)
    v_weight = in_power.rgb * scatter_weight * phase_eval(dot(in_dir_t.xyz, w)) * exp(-sigma_t * camera_depth(c));
#else
    v_weight = in_power.rgb * scatter_weight * phase_eval(dot(in_dir_t.xyz, w)) * exp(-sigma_t * dist);
#endif
    v_center = c;
#ifdef SPLAT_ADAPTIVE
    // splat = adaptive: the photon's own kernel (in_dir_t.w, splat/compact.comp.glsl),
    // integrated over each pixel's area (splat.frag.glsl), so that a kernel of any width,
    // narrower than a pixel too, keeps its integral. It is cut to the square ±TRUNCATION·σ
    // (renormalised), so the billboard reaches TRUNCATION·σ and a pixel: every pixel that
    // overlaps the square has its centre within TRUNCATION·σ + ½ pixel (a pixel at the
    // splat spans at most v_pixel: off axis it spans less). A splat without one (0) takes
    // splat_radius, point-sampled as the paper's.
    vec4 centre_clip = view_proj * vec4(c, 1.0);
    v_center_px = (centre_clip.xy / centre_clip.w * 0.5 + 0.5) * viewport;
#ifdef SPLAT_DENSITY
    bool boxed = true;
    float sigma = density_sigma(v_center_px, viewport, dist, pixel_angle, splat_radius);
#else
    bool boxed = in_dir_t.w > 0.0;
    float sigma = boxed ? in_dir_t.w : splat_radius;
#endif
    v_sigma = sigma;
    v_pixel = boxed ? pixel_angle * dist : 0.0;
    float R = TRUNCATION * sigma + (boxed ? v_pixel : 0.0);
#else
    float R = TRUNCATION * splat_radius;
#endif
    float extent = R * dist / sqrt(max(dist * dist - R * R, 1e-4 * R * R));
    vec3 helper = abs(w.y) < 0.99 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 right = normalize(cross(helper, w));
    vec3 up = cross(w, right);
    v_corner = c + (in_corner.x * right + in_corner.y * up) * extent;
    gl_Position = view_proj * vec4(v_corner, 1.0);
}
