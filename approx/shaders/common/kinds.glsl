// Shape kinds: what a camera ray hit, in the G-buffer's channel y (camera/gbuffer.frag.glsl).
// One source: scenes/formats.py (KIND_*); the loader (approx/glsl.py) defines them
// before this file, and these defaults only stand in when it is compiled on its own.
// KIND_NONE is 0: a G-buffer cleared to zero reads as "no surface".
#ifndef VOLCAUSTICS_KINDS_GLSL
#define VOLCAUSTICS_KINDS_GLSL

#ifndef KIND_NONE
#define KIND_NONE 0      // nothing (the ray leaves the scene)
#endif
#ifndef KIND_SPECULAR
#define KIND_SPECULAR 1  // a specular (glass) object
#endif
#ifndef KIND_DIFFUSE
#define KIND_DIFFUSE 2   // a diffuse (Lambertian) surface
#endif
#ifndef KIND_BOUNDARY
#define KIND_BOUNDARY 3  // the medium box (reference only)
#endif

// The kind stored in a G-buffer geometry texel (distance to eye, kind, material, 0).
int gbuffer_kind(vec4 geometry) {
    return int(geometry.y + 0.5);
}

#endif
