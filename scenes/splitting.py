"""Fresnel splitting along the refracted chain (the parameter ``fresnel_splits``): the rule
the GPU tracer (``approx/shaders/common/split.glsl``) and both exact replays
(``reference.oracle``, ``reference.wavefront``) follow.

With k splits a frame traces k + 1 batches of photon_res² photon slots: slot
j = b·N + i (N = photon_res², the batch's ``slots``) is emission texel i's photon in
batch b. The interactions are numbered as the Fresnel numbers' ``step`` (0: the
emission's, at the first surface; s: trace step s's).

* batch b < k refracts at interactions 0..b−1, **reflects** at b, and chooses as
  ``fresnel`` says after it;
* batch k refracts at interactions 0..k−1 and chooses after them.

A forced reflection carries R of the photon's power, a forced refraction 1 − R of it
(R = 1 under total internal reflection: a forced refraction there carries nothing), so
the k + 1 batches hold the k first branches of every photon's tree whole — each
reflection off the refracted chain, which a choice by R takes with probability R, is
traced by every photon at R of its power. Batch b < k follows the refracted chain to its
reflection: its segments of steps 1..b are batch k's and are not splatted
(:func:`silent`), so that each branch is counted once. The sum over the batches has the
expectation of one photon choosing at every interaction (``tests/approx/test_splits.py``).

With ``split_every`` = m > 1 a reflected batch (b < k) keeps one photon in m of its slots,
chosen by stratified numbers over the texels (``scenes.rng.stratified(seed, texel, b,
SPLIT_DIM)`` below 1/m: about N/m of them, evenly spread), at m times its power
(:func:`kept`): a reflected beam costs a frame as much as any other, and carries R ≈ 4–10%
of the light, so it needs fewer photons than the refracted chain.

Why: where R is small the reflected light is made by few photons, and its noise is a
frame's largest share (docs/decisions.md "Splitting at the first surfaces").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from volcaustics.scenes.rng import stratified

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

FREE, REFLECT, REFRACT = 0, 1, 2  # what a photon does at an interaction
SPLIT_DIM = 4  # the dimension of a reflected batch's keep numbers (scenes.rng: 0 free flight, 1 Fresnel, 2–3 jitter)
# the numbers a forced choice puts in place of the Fresnel number (common/interaction.glsl):
# below 0 reflects at R of the power, above 1 refracts at 1 − R, whatever the fresnel mode
FORCED_NUMBER = {REFLECT: -1.0, REFRACT: 2.0}


def forced(photon: ArrayLike, step: ArrayLike, splits: int, slots: int) -> np.ndarray:
    """FREE, REFLECT or REFRACT for photon slot ``photon`` at interaction ``step`` (0: the
    emission's) of a frame with ``splits`` splits over batches of ``slots`` slots."""
    batch = np.asarray(photon, np.int64) // max(slots, 1)
    step = np.asarray(step, np.int64)
    chain = step < np.minimum(batch, splits)
    off = (step == batch) & (batch < splits)
    return np.where(chain, REFRACT, np.where(off, REFLECT, FREE))


def split_number(xi: np.ndarray, photon: ArrayLike, step: ArrayLike, splits: int, slots: int) -> np.ndarray:
    """The Fresnel numbers ``xi`` with each forced choice's :data:`FORCED_NUMBER` in place."""
    if splits == 0:
        return xi
    choice = forced(photon, step, splits, slots)
    return np.where(choice == REFLECT, FORCED_NUMBER[REFLECT],
                    np.where(choice == REFRACT, FORCED_NUMBER[REFRACT], xi)).astype(np.asarray(xi).dtype)


def silent(photon: ArrayLike, step: ArrayLike, splits: int, slots: int) -> np.ndarray:
    """Whether the segment of ``step`` (1-based, a record's) of photon slot ``photon`` is
    another batch's (not splatted): batch b < ``splits``' steps 1..b."""
    batch = np.asarray(photon, np.int64) // max(slots, 1)
    return (batch < splits) & (np.asarray(step, np.int64) <= batch)


def split_rays(photon: np.ndarray, splits: int, slots: int) -> np.ndarray:
    """The photon slots of every batch for emission photons ``photon`` (< ``slots``):
    batch-major, (splits + 1)·len(photon) indices b·slots + photon."""
    photon = np.asarray(photon, np.int64)
    return (np.arange(splits + 1, dtype=np.int64)[:, None] * slots + photon[None, :]).ravel()


def kept(seed: int, photon: ArrayLike, splits: int, slots: int, every: int) -> tuple[np.ndarray, np.ndarray]:
    """(whether photon slot ``photon`` is emitted, the factor on its power) under
    ``split_every`` = ``every``: a reflected batch's slot kept where its stratified number
    is below 1/every, at ``every`` times the power; batch ``splits``' always, at 1."""
    photon = np.asarray(photon, np.int64)
    batch = photon // max(slots, 1)
    reflected = batch < splits
    if every == 1 or not splits:
        return np.ones(photon.shape, bool), np.ones(photon.shape)
    u = stratified(seed, (photon % slots).astype(np.uint32), batch.astype(np.uint32), SPLIT_DIM)
    keep = ~reflected | (u < np.float32(1.0 / every))
    return keep, np.where(reflected, float(every), 1.0)


@dataclass
class SplitRays:
    """Rays of every batch of a split emission (:func:`split_groups`): ``reference.replay.Rays``' fields."""

    photon: np.ndarray
    direction: np.ndarray
    power: np.ndarray


def split_groups(groups: Sequence[tuple[Any, int]], splits: int, slots: int, every: int = 1) -> list:
    """``groups`` with every set of rays repeated over the fresnel_splits + 1 batches
    (module docstring) (photon b·``slots`` + p, batch-major), the reflected batches'
    rays kept and weighted as split_every = ``every`` says (:func:`kept`,
    which depends on the seed), each set once for the groups that share it and a seed;
    the groups themselves when ``splits`` is 0."""
    if not splits:
        return list(groups)
    made: dict = {}

    def key(rays, seed):  # the kept slots depend on the seed only with split_every > 1
        return id(rays), seed if every > 1 else None

    for rays, seed in groups:
        if key(rays, seed) not in made:
            copies = splits + 1
            photon = split_rays(np.asarray(rays.photon), splits, slots)
            keep, factor = kept(seed, photon, splits, slots, every)
            direction = np.tile(np.asarray(rays.direction), (copies, 1))[keep]
            power = np.tile(np.asarray(rays.power), (copies, 1))[keep] * factor[keep, None]
            made[key(rays, seed)] = SplitRays(photon[keep].astype(np.uint32), direction, power)
    return [(made[key(rays, seed)], seed) for rays, seed in groups]
