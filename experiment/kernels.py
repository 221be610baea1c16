"""Which kernel each image of the decomposition is splatted with
(docs/concepts/decomposition.md, "Kernels that depend on the photons").

One rule for every splat mode: **every image of a seed takes its kernel widths from
that seed's real frame**, so that each term changes one thing and the decomposition's A
image is the real frames' mean:

* ``fixed``: splat_radius for every photon (nothing depends on the photons); ``beams``
  the same for every beam (beam_width = fixed);
* ``adaptive``: the kernel A gave the same photon (emission texel) at the same step
  (its ray differential's footprint), else, for a photon A did not splat there (another
  path, or a step beyond A's), the median of A's kernels; ``beams`` with beam_width =
  differential the same rule for a beam's kernel at its start and its rate along it
  (A's median σ0 at rate 0 where A has none);
* ``density``: the width the density pre-pass of A's own collisions of the photon's step
  gives at the photon's position (``approx.Renderer.density_widths``: the frame's
  pre-pass and width, by transform feedback), for a step beyond A's ``steps`` A's last
  step's. A subset of photons or an exact replay is splatted with the widths the real
  frame had where it lands, not with widths from its own (sparser or denser) photons.

E_∞,s is not splatted with these: it always takes the fixed small kernel
(``exact_images.small_radius``). A kernel of A's field is drawn by the splatter's
per-splat path (``splat = adaptive``: each splat's own σ, integrated over each pixel),
which with the same σ draws the very fragments the density splat pass draws.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from volcaustics.approx.params import differential_beams
from volcaustics.approx.splat import record_kernels, splats_from_arrays, with_kernels
from volcaustics.approx.splat_modes import splat_mode

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Renderer
    from volcaustics.scenes.model import Scene

#: What summary.json says of the kernels of the decomposition's images, per splat mode.
KERNEL_RULES = {
    "fixed": "splat_radius for every image",
    "adaptive": "A's kernel of the same photon and step (A's median where A has none)",
    "density": "the density field of A's own collisions of the photon's step (beyond A's steps: its last)",
    "beams": "splat_radius for every beam",
    "beams, differential": "A's kernel (σ at the start, its rate) of the same photon and step (A's median σ, "
                           "rate 0, where A has none)",
}


def kernel_rule(p: ApproxParams) -> str:
    """What summary.json says of the decomposition's kernels for ``p`` (KERNEL_RULES)."""
    if differential_beams(p):
        return KERNEL_RULES["beams, differential"]
    return KERNEL_RULES[p.splat]

#: splats, photon indices, steps → the same splats with their kernel σ (SPLAT_DTYPE dir.w)
Kernels = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def splat_params(p: ApproxParams) -> ApproxParams:
    """The parameters an image with a frame's kernels is splatted with: ``p`` itself for
    fixed and adaptive splats; for density splats the per-splat path (``splat =
    adaptive``), which draws each splat with the σ it carries."""
    return dataclasses.replace(p, splat="adaptive") if splat_mode(p).density_pass else p


def frame_kernels(renderer: Renderer, scene: Scene, p: ApproxParams, collided: np.ndarray) -> Kernels:
    """The kernels of a seed's real frame, for any photons of that seed.

    Parameters
    ----------
    renderer : the ``approx.Renderer`` of ``scene`` (density widths are its pass).
    p : the frame's resolved ``approx.ApproxParams``.
    collided : the frame's medium collisions, RECORD_DTYPE rows of every step
        (``photon``, ``step``, ``end``, ``direction``, ``power``, ``footprint``).
    """
    own = record_kernels(collided, p)
    if own is not None:  # adaptive splats, differential beams: per-record kernels
        return _paired(collided, own)
    if splat_mode(p).density_pass:
        return _density_field(renderer, scene, p, collided)
    return lambda splats, photon, step: splats


def _paired(collided: np.ndarray, own: np.ndarray) -> Kernels:
    """Adaptive splats and differential beams: the kernel (``own``, N×2: σ and its rate
    along a beam, ``approx.splat.record_kernels``) of the same photon's row at the same
    step of A (``collided``), else A's median σ at rate 0."""
    order = np.lexsort((collided["step"], collided["photon"]))
    keys = collided["photon"][order].astype(np.int64) << 16 | collided["step"][order].astype(np.int64)
    sorted_own = own[order]
    fallback = np.array([np.median(own[:, 0]) if len(own) else 0.0, 0.0], np.float32)

    def kernels(splats, photon, step):
        if not len(keys):
            return with_kernels(splats, np.tile(fallback, (len(splats), 1)))
        wanted = np.asarray(photon, np.int64) << 16 | np.asarray(step, np.int64)
        at = np.clip(np.searchsorted(keys, wanted), 0, len(keys) - 1)
        return with_kernels(splats, np.where((keys[at] == wanted)[:, None], sorted_own[at], fallback))

    return kernels


def _density_field(renderer, scene, p, collided: np.ndarray) -> Kernels:
    """Density splats: per step j ≤ ``p.steps`` the field of A's step-j collisions; a
    photon at step s takes the field of step min(s, steps)."""
    fields = {}
    for step in range(1, p.steps + 1):
        c = collided[collided["step"] == step]
        fields[step] = splats_from_arrays(c["end"], c["direction"], c["power"])

    def kernels(splats, photon, step):
        out = splats.copy()
        group = np.minimum(np.asarray(step), p.steps)
        for j in np.unique(group):
            mine = group == j
            out["dir"][mine, 3] = renderer.density_widths(splats[mine], fields[int(j)], scene, p)
        return out

    return kernels
