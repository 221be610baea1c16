"""Formats every package shares: photon and segment-record layouts, status and
flag codes, shape kinds and the names of a frame's component images.

This module is their one source. The GPU tracer's std430 structs
(``approx/shaders/common/photon.glsl``) are tied to the dtypes here by a test
(``tests/approx/test_formats_glsl.py``), and the codes reach the shaders as
``#define`` lines through the GLSL loader (``approx.glsl.SHARED_DEFINES``).

All dtypes are little-endian; positions are world coordinates in metres,
directions unit vectors, powers radiant flux in W (RGB).
"""

from __future__ import annotations

import numpy as np

from volcaustics.infra.imageio import MASK_LAYER  # re-exported: the image files name the one-channel layer

# --- how far ground truth follows light: interactions (surface hits and medium collisions) of
# an exact photon path (the decomposition's E_∞, experiment.exact_images) and, at
# most as many, segments of a reference light path (reference.render.integrators). Light
# trapped by total internal reflection (the held-out knot's tube) kept 0.3-0.4% of its
# power after 128; after 512 < 0.1% on every built-in and held-out scene (docs/decisions.md
# "Exact steps and the small kernel")
PATH_INTERACTIONS = 512

# --- photon status (Photon.dir.w, Record.end_status.w, RECORD_DTYPE["status"])
STATUS_DEAD = 0        # no photon here, or terminated earlier
STATUS_SURFACE = 1     # ended at a specular surface (after the interaction there)
STATUS_COLLIDED = 2    # ended at a medium collision: splatted for this step
STATUS_LEFT_SCENE = 3  # left the scene box: terminated
STATUS_LOST = 4        # inside glass and no exit found: terminated

STATUS_NAMES = {STATUS_DEAD: "dead", STATUS_SURFACE: "surface", STATUS_COLLIDED: "collided",
                STATUS_LEFT_SCENE: "left_scene", STATUS_LOST: "lost"}

def splatted_mask(inside: np.ndarray, status: np.ndarray, beams: bool) -> np.ndarray:
    """Which segments a step splats, from the medium (``inside`` < 0) or glass it started
    in and its status after the step: the medium collisions, or with ``beams`` (splat =
    beams) the segments in the medium that reached a surface or the medium's end (the
    numpy twin of splat/compact.comp.glsl's rule)."""
    if beams:
        return (np.asarray(inside) < 0) & np.isin(status, (STATUS_SURFACE, STATUS_LEFT_SCENE))
    return np.asarray(status) == STATUS_COLLIDED


# --- flag bits of a segment (Record.extra.x, RECORD_DTYPE["flags"])
FLAG_LEFT_FRUSTUM = 1  # part of the segment lay outside the light maps
FLAG_REFLECTED = 2     # the interaction at the end reflected (Fresnel choice or TIR)
FLAG_TIR = 4           # total internal reflection at the end
FLAG_WITHIN_OFFSET = 8  # inside glass, the exit was found within the start offset (nothing beyond it)

# --- shape kinds: what a ray hit (approx G-buffer channel y, reference ShapeTable).
# KIND_NONE is 0 so that a G-buffer cleared to zero reads as "no surface".
KIND_NONE = 0      # nothing (the ray leaves the scene)
KIND_SPECULAR = 1  # a specular (glass) object
KIND_DIFFUSE = 2   # a diffuse (Lambertian) surface
KIND_BOUNDARY = 3  # the medium box (reference only: the exported scene's boundary shape)

# Every code by the name both languages spell it with (the GLSL loader defines these).
STATUS_CODES = {"STATUS_DEAD": STATUS_DEAD, "STATUS_SURFACE": STATUS_SURFACE, "STATUS_COLLIDED": STATUS_COLLIDED,
                "STATUS_LEFT_SCENE": STATUS_LEFT_SCENE, "STATUS_LOST": STATUS_LOST}
FLAG_BITS = {"FLAG_LEFT_FRUSTUM": FLAG_LEFT_FRUSTUM, "FLAG_REFLECTED": FLAG_REFLECTED, "FLAG_TIR": FLAG_TIR,
             "FLAG_WITHIN_OFFSET": FLAG_WITHIN_OFFSET}
SHAPE_KINDS = {"KIND_NONE": KIND_NONE, "KIND_SPECULAR": KIND_SPECULAR, "KIND_DIFFUSE": KIND_DIFFUSE,
               "KIND_BOUNDARY": KIND_BOUNDARY}

# --- component images of a frame (docs/conventions.md)
COLOUR_LAYERS = ("caustic", "fog", "direct", "combined")  # H×W×3 float32 radiance, W·m⁻²·sr⁻¹
LAYER_NAMES = COLOUR_LAYERS + (MASK_LAYER,)
# A reference rendered with K > 1 scattering orders also holds, per colour layer, what the
# orders beyond the paper's single-scattering model add: R_ms − R_ss, the model term
MODEL_LAYERS = tuple(f"{name}_ms" for name in COLOUR_LAYERS)
# What each layer holds (docs/conventions.md's table), for files that tell other programs (glTF extras)
LAYER_MEANINGS = {
    "caustic": "single-scattered radiance from light that crossed >= 1 specular interface before scattering in the "
               "medium, seen directly by the camera (the volume caustic)",
    "fog": "single-scattered radiance from direct (unrefracted) light, with volumetric shadows of all objects",
    "direct": "direct lighting on diffuse surfaces, attenuated by the medium both ways, shadowed",
    "combined": "sum of caustic, fog and direct",
    **{f"{name}_ms": f"what scattering orders 2..K in the medium add to {name} (R_ms - R_ss; for direct, light "
                     "that scattered 1..K times before reaching the surface)" for name in COLOUR_LAYERS},
    MASK_LAYER: "1 where the primary camera ray hits a specular object, else 0 (excluded from image metrics: what "
                "is seen through glass is modelled by neither technique in the same way)",
}

# --- photon arrays
# One photon slot of the GPU tracer (std430 struct Photon, 48 bytes):
#   pos    xyz position (m); w: specular object the photon is inside, -1 in the medium
#   dir    xyz unit direction; w: STATUS_*
#   power  rgb power (W); w: start offset of the next segment, in light-map texel footprints
PHOTON_DTYPE = np.dtype([("pos", "<f4", 4), ("dir", "<f4", 4), ("power", "<f4", 4)])

# A photon's ray differential (splat = adaptive only: a buffer of its own, std430 vec2, so
# that the paper's program moves no more memory): the footprint, the signed distance to
# its neighbours' rays where it is (m), and its rate of change along the ray (m/m).
DIFFERENTIAL_DTYPE = np.dtype([("footprint", "<f4"), ("rate", "<f4")])

# One photon to splat, a medium collision (std430 struct Splat, 48 bytes):
#   center_status  xyz collision point (m); w: STATUS_COLLIDED
#   dir            xyz propagation direction before scattering (unit); w: the kernel's
#                  standard deviation (m) when splat = adaptive, 0: the uniform splat_radius
#   power          rgb power at the collision, after transmittance (W); w unused
SPLAT_DTYPE = np.dtype([("center_status", "<f4", 4), ("dir", "<f4", 4), ("power", "<f4", 4)])

# One photon beam to splat, a photon's segment in the medium (splat = beams; std430 struct
# Beam, 48 bytes):
#   start_length  xyz where the segment starts (m); w: its length to the next surface or
#                 the medium's end (m)
#   dir           xyz unit direction; w: the kernel's standard deviation (m), 0: splat_radius
#   power         rgb power at the start (W), before the medium's transmittance; w unused
BEAM_DTYPE = np.dtype([("start_length", "<f4", 4), ("dir", "<f4", 4), ("power", "<f4", 4)])

# --- segment records
# One segment as the GPU tracer writes it (std430 struct Record, 112 bytes):
#   start_maxlen  xyz segment start (m); w: sampled max length (free flight, or scene span inside glass)
#   dir_t         xyz unit direction; w: estimated hit distance t (m), -1 if no hit
#   normal_map    xyz estimated normal at the hit; w: map index, -1 if no hit
#   end_status    xyz end position (m); w: STATUS_* after the step
#   power_inside  rgb power after the step (W); w: specular object inside at the start, -1 in the medium
#   extra         x: FLAG_* bits; y: specular object hit (-1 none); z: segment length searched (m);
#                 w: start offset (m)
#   power_start   rgb power at the segment start (W); w: map texels the search read (map_reads)
RAW_RECORD_DTYPE = np.dtype([("start_maxlen", "<f4", 4), ("dir_t", "<f4", 4), ("normal_map", "<f4", 4),
                             ("end_status", "<f4", 4), ("power_inside", "<f4", 4), ("extra", "<f4", 4),
                             ("power_start", "<f4", 4)])

# One segment as metrics read it, from the GPU tracer (approx.records.records_from_raw)
# or the exact photon tracer (reference.oracle.exact_photon_records).
RECORD_DTYPE = np.dtype([
    ("photon", "<u4"),          # photon index = emission texel (row * photon_res + column)
    ("step", "<u2"),            # interaction step, 1..steps
    ("start", "<f4", 3),        # segment start (world, m)
    ("direction", "<f4", 3),    # unit direction
    ("max_length", "<f4"),      # sampled free-flight distance (medium) or scene span (inside glass), m
    ("search_length", "<f4"),   # length actually searched (max_length clipped to the scene box), m
    ("start_offset", "<f4"),    # the search began this far from the start (m; 0 for the exact tracer)
    ("t", "<f4"),               # estimated first-hit distance (m), nan if no hit
    ("hit", "?"),
    ("map", "<i2"),             # light map of the hit: 2 * layer + (0 front, 1 back); -1 if no hit
    ("normal", "<f4", 3),       # estimated normal at the hit (nan if no hit)
    ("material", "<i2"),        # specular object hit (-1 none)
    ("inside", "<i2"),          # specular object the segment runs inside (-1: medium)
    ("end", "<f4", 3),          # where the step ended (m)
    ("power_start", "<f4", 3),  # power at the segment start (W, RGB)
    ("power", "<f4", 3),        # power after the step (W, RGB)
    ("status", "<u1"),          # STATUS_* after the step
    ("flags", "<u1"),           # FLAG_* bits
    ("map_reads", "<u4"),       # light-map texels the search read (0 for the exact tracer): cost across hardware
    ("footprint", "<f4"),       # splat = adaptive: the photon's ray-differential footprint where the step
                                # ended (m, signed; DIFFERENTIAL_DTYPE); beam_width = differential: at the
                                # segment's start; 0 otherwise and for the exact tracer
    ("footprint_rate", "<f4"),  # beam_width = differential: the footprint's rate along the segment (m/m); else 0
])
