"""A frame's cost that travels across hardware (docs/approx.md: the
light-map texels it reads and the photons it splats. llvmpipe wall time is reported
beside it, never instead: the method's claims are about GPUs.

``map_reads`` are the search's (every traced segment's, counted by the trace shader),
``emission_reads`` the emission's (``approx.emission.emission_reads``: what adaptive
emission's importance pass and adaptive splats' curvature add), ``splats`` the medium
collisions splatted over all steps (splat = beams: the beams), ``density_reads`` the density pre-pass's (splat =
density: a write and a bilinear read per splat), ``medium_reads`` a heterogeneous medium's
(its density grid's samples and its transmittance volumes' reads, :data:`MEDIUM_PARTS`; 0 in
a homogeneous one). ``total`` = map reads + emission reads + splats + density reads +
medium reads: one texel read, one sample of ρ or one splat, each a unit (the fog, direct
and camera passes cost the same for every parameter but the image size and fog_steps, and
are left out, but for their medium reads).

Beside the total, every count that a parameter scales (docs/concepts/equal-cost.md):
``photons`` launched (the emission's, alive after it), ``segments`` (photon-steps traced:
the trace loop's iterations over photons, summed over the steps), ``lookups`` (the
search loops' iterations: map distances looked up, from memory or registers; one atomic
add per photon and step counts them), ``lockstep_lookups`` (the same in lockstep: per
subgroup of the trace, its longest photon's lookups × its size, what a SIMD machine
spends while its lanes wait for the last), and per raster pass
the fragments it wrote (``fragments_<pass>``, GL samples-passed queries of the frame:
``Frame.work``), which the splat pass's footprint drives, and per pass that draws the
scene's meshes the primitives it drew (``primitives_<pass>``, ``Frame.work``: the
light layers draw every mesh twice per layer, which their written fragments do not show),
and the splat pass's shaded fragments (``shaded_splat``: fragment shader invocations,
discards included, ``approx.invocations``; NaN where the driver cannot count them): a
beam's quad is shaded over far more pixels than it writes.

A heterogeneous medium's reads, per pass (``medium_reads_<pass>``; docs/concepts/
heterogeneous-media.md): ``volumes`` one sample of ρ per texel of the camera and light
volumes; ``emission`` the light path's march, ``march_steps`` per photon; ``trace`` delta
tracking's tentative collisions and the segments' marches (counted by the trace shader:
``Frame.work``'s ``medium_reads``); ``splat`` a point splat's camera-volume read in each of
its quad's 4 corners, a beam fragment's march along the beam, its ρ and its camera-volume
read (``march_steps`` + 2 per shaded fragment); ``fog`` ρ and both volumes at each fog step
(3 per fog fragment and step); ``direct`` both volumes (2 per fragment).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import numpy as np

from .denoise import DENOISED
from .emission import emission_reads
from .params import carries_differentials
from .splat import splatted
from .splat_modes import splat_mode

if TYPE_CHECKING:
    from .params import ApproxParams

# denoised_pixels (denoise = oidn, approx.denoise): beside the cost, never in its total
# a frame's passes as Frame.timings names them (trace: its steps summed), in frame order
# (volumes: a heterogeneous medium's transmittance volumes, approx.medium_volumes; none in a homogeneous one)
TIMED_PASSES = ("volumes", "layers", "emission", "camera", "trace", "density", "splat", "fog", "direct")
# the raster passes whose fragments a frame counts (approx.renderer: density only with splat = density)
FRAGMENT_PASSES = tuple(name for name in TIMED_PASSES if name not in ("volumes", "trace"))
# the passes that draw the scene's meshes: their primitives are counted
MESH_PASSES = ("layers", "emission", "camera")
# the passes that read a heterogeneous medium (``medium_reads_<pass>``; "volumes" makes its two volumes)
MEDIUM_PARTS = ("volumes", "emission", "trace", "splat", "fog", "direct")
COST_FIELDS = ("map_reads", "emission_reads", "splats", "density_reads", "medium_reads", "total", "denoised_pixels",
               "photons", "segments", "lookups", "lockstep_lookups",
               *(f"fragments_{name}" for name in FRAGMENT_PASSES),
               *(f"primitives_{name}" for name in MESH_PASSES), "shaded_splat",
               *(f"medium_reads_{name}" for name in MEDIUM_PARTS))
# splat = density: each splat writes its cell in the pre-pass and reads the grid (4 texels, bilinear) for its width
DENSITY_READS = 5


def frame_cost(records: list, params: ApproxParams, work: dict | None = None) -> dict:
    """One frame's cost (COST_FIELDS) from its per-step records (``Frame.records``),
    its resolved parameters and its counted work (``Frame.work``: fragments and
    primitives per pass, the trace loop's lookups, own and lockstep, and its medium reads;
    None: those fields are NaN, the medium reads too, and the total is without them)."""
    fragments = None if work is None else work["fragments"]
    primitives = None if work is None else work["primitives"]
    search = sum(int(np.asarray(r["map_reads"], np.int64).sum()) for r in records)
    splats = sum(int(np.count_nonzero(splatted(r, params))) for r in records)
    emitted = len(records[0]) if records else 0
    emission = emission_reads(params.photon_res, emitted, emission=params.emission,
                              differentials=carries_differentials(params))
    # resolved parameters: width and height set
    denoised = len(DENOISED) * cast(int, params.width) * cast(int, params.height) if params.denoise == "oidn" else 0
    density = DENSITY_READS * splats if splat_mode(params).density_pass else 0
    counted = {f"fragments_{name}": float("nan") if fragments is None else int(fragments.get(name, 0))
               for name in FRAGMENT_PASSES}
    counted.update({f"primitives_{name}": float("nan") if primitives is None else int(primitives.get(name, 0))
                    for name in MESH_PASSES})
    shaded = None if work is None else work.get("shaded", {}).get("splat")
    counted["shaded_splat"] = float("nan") if shaded is None else int(shaded)
    medium = medium_reads(params, work, emitted, splats, counted)
    counted.update({f"medium_reads_{name}": v for name, v in medium.items()})
    reads = sum(medium.values())  # NaN where not counted (no work): then not in the total
    known = reads if reads == reads else 0
    return {"map_reads": search, "emission_reads": emission, "splats": splats, "density_reads": density,
            "medium_reads": reads, "total": search + emission + splats + density + known, "denoised_pixels": denoised,
            "photons": emitted,
            "segments": sum(len(r) for r in records),
            **{name: float("nan") if work is None else int(work[name]) for name in ("lookups", "lockstep_lookups")},
            **counted}


def medium_reads(params: ApproxParams, work: dict | None, photons: int, splats: int, counted: dict) -> dict:
    """pass → a heterogeneous medium's reads in it (MEDIUM_PARTS; the module's docstring):
    all 0 in a homogeneous medium (``work``'s ``heterogeneous`` false), NaN where ``work``
    is None (not counted). ``counted``: the frame's fragments per pass and shaded splat
    fragments (:func:`frame_cost`'s)."""
    if work is None:
        return {name: float("nan") for name in MEDIUM_PARTS}
    if not work.get("heterogeneous"):
        return {name: 0 for name in MEDIUM_PARTS}
    march = int(params.march_steps)
    volumes = (int(params.camera_volume_res) ** 2 * int(params.camera_volume_slices)
               + int(params.light_volume_res) ** 2 * int(params.light_volume_slices))
    if splat_mode(params).beams:
        shaded = counted["shaded_splat"]
        fragments = shaded if shaded == shaded else counted["fragments_splat"]  # NaN: not counted, the written
        splat = (march + 2) * fragments
    else:
        splat = 4 * splats
    return {"volumes": volumes, "emission": march * photons, "trace": int(work["medium_reads"]), "splat": splat,
            "fog": 3 * int(params.fog_steps) * counted["fragments_fog"], "direct": 2 * counted["fragments_direct"]}
