// splat = density: a splat's kernel width from the photons per cell of the pre-pass
// (density.vert.glsl) around its centre, read bilinearly: the radius in pixels of a disc
// that holds splat_neighbours photons, r = √(k / (π·ρ)) with ρ photons per pixel², as the
// k-th nearest neighbour's distance estimates it (in 2-D: h ∝ f^(−1/2), Abramson's
// square-root law), taken as σ and carried to the splat's distance; within
// [density_floor, 4]·splat_radius. Shared by the splat pass (splat.vert.glsl) and the
// widths pass (widths.vert.glsl), so both give a splat the same σ.
#ifndef VOLCAUSTICS_DENSITY_WIDTH_GLSL
#define VOLCAUSTICS_DENSITY_WIDTH_GLSL
uniform sampler2D density;     // photons per cell (density.vert.glsl)
uniform float density_cell;    // a cell's side (pixels)
uniform float splat_neighbours;
#ifdef DENSITY_IGNORED
// the splat pass's indirect draw command (approx.splat.SPLAT_COMMANDS): its instances are the
// frame's splats, counted on the GPU
layout(std140) uniform SplatCommands { uint command_vertices; uint splat_count; };
#endif
uniform float density_floor;   // the narrowest kernel, in splat_radius (approx.splat.DENSITY_FLOOR)

// σ (m) of a splat whose centre lies at window coordinates center_px (pixels) of an image
// of size viewport, dist metres from the eye; pixel_angle: a pixel's width per metre.
float density_sigma(vec2 center_px, vec2 viewport, float dist, float pixel_angle, float splat_radius) {
#ifdef DENSITY_IGNORED
    // a test's negative control: one width for the frame's photons, their mean per pixel²
    float per_pixel = float(splat_count) / (viewport.x * viewport.y);
#else
    float per_pixel = max(texture(density, center_px / viewport).r, 1.0) / (density_cell * density_cell);
#endif
    float r = sqrt(splat_neighbours / (3.141592653589793 * per_pixel));
    return clamp(r * pixel_angle * dist, density_floor * splat_radius, 4.0 * splat_radius);
}
#endif
