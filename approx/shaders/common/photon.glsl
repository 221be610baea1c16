// Photon state and per-step segment records (std430). One source for these
// layouts and codes: scenes/formats.py (PHOTON_DTYPE, RAW_RECORD_DTYPE,
// SPLAT_DTYPE; STATUS_*, FLAG_*), tied to this file by tests/approx/test_formats_glsl.py.
#ifndef VOLCAUSTICS_PHOTON_GLSL
#define VOLCAUSTICS_PHOTON_GLSL

// The loader (approx/glsl.py) defines the codes from scenes/formats.py before
// this file; these defaults only stand in when the file is compiled on its own.
// status (photon.dir.w and record.end_status.w)
#ifndef STATUS_DEAD
#define STATUS_DEAD 0        // no photon here, or terminated earlier
#endif
#ifndef STATUS_SURFACE
#define STATUS_SURFACE 1     // ended at a specular surface (after the interaction there)
#endif
#ifndef STATUS_COLLIDED
#define STATUS_COLLIDED 2    // ended at a medium collision: splatted for this step
#endif
#ifndef STATUS_LEFT_SCENE
#define STATUS_LEFT_SCENE 3  // left the scene box: terminated
#endif
#ifndef STATUS_LOST
#define STATUS_LOST 4        // inside glass and no exit found: terminated
#endif

// flags (record.extra.x)
#ifndef FLAG_LEFT_FRUSTUM
#define FLAG_LEFT_FRUSTUM 1u // part of the segment lay outside the light maps
#endif
#ifndef FLAG_REFLECTED
#define FLAG_REFLECTED 2u    // the interaction at the end reflected (Fresnel choice or TIR)
#endif
#ifndef FLAG_TIR
#define FLAG_TIR 4u          // total internal reflection at the end
#endif
#ifndef FLAG_WITHIN_OFFSET
#define FLAG_WITHIN_OFFSET 8u // inside glass, the exit was found within the start offset
#endif

struct Photon {
    vec4 pos;    // xyz position; w: material id of the glass it is inside, -1 in the medium
    vec4 dir;    // xyz unit direction; w: status
    vec4 power;  // rgb power (W); w: start offset of the next segment in light-map texel footprints
                 // (start rule `id`: primitive id + 1 of the triangle it leaves, 0 none)
};

struct Record {
    vec4 start_maxlen;  // xyz segment start; w: sampled max length (free flight, or scene span inside glass)
    vec4 dir_t;         // xyz direction; w: estimated hit distance t, -1 if no hit
    vec4 normal_map;    // xyz estimated normal at the hit (world); w: map index, -1 if no hit
    vec4 end_status;    // xyz end position; w: status after the step
    vec4 power_inside;  // rgb power after the step; w: material id inside at the start, -1 in the medium
    vec4 extra;         // x: flags; y: material id hit (-1 none); z: segment length searched; w: start offset (m)
    vec4 power_start;   // rgb power at the segment start; w: map texels the search read (map_reads)
};

// A photon to splat (compacted list of this step's medium collisions).
struct Splat {
    vec4 center_status;  // xyz collision point; w: STATUS_COLLIDED
    vec4 dir;            // xyz propagation direction before scattering; w: kernel σ (m), 0: splat_radius
    vec4 power;          // rgb power at the collision (after transmittance)
};

// A photon beam to splat (splat = beams: compacted list of this step's medium segments).
struct Beam {
    vec4 start_length;  // xyz segment start; w: its length to the next surface or the medium's end (m)
    vec4 dir;           // xyz unit direction; w: kernel σ (m), 0: splat_radius
    vec4 power;         // rgb power at the start (before the medium's transmittance); w: the kernel σ's
                        // rate along the beam (m/m; beam_width = differential, else 0)
};

#endif
