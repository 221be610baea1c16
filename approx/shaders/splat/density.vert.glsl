// splat = density, the pre-pass: every medium collision as one point in a coarse grid
// of the image (DENSITY_CELL pixels a side), each adding 1: the photons per cell, which
// the splat pass reads at its centre for its kernel's width (splat.vert.glsl).
#include "common/photon.glsl"

uniform mat4 view_proj;

in vec4 in_end;  // per instance: record.end_status

void main() {
    gl_PointSize = 1.0;
    if (int(in_end.w + 0.5) != STATUS_COLLIDED) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume
        return;
    }
    gl_Position = view_proj * vec4(in_end.xyz, 1.0);
}
