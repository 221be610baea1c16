"""The exact caustic images of the decomposition, as paired photon subsets: A, E_k,
E_∞ (A's Fresnel), E_∞ (stochastic) and E_∞,s (small kernel, supersampled). With
splat = adaptive, A is splatted with its own kernels and the E images with the kernels
A gave the same photons (:func:`_paired_kernels`), so kernel_blur = E_∞ − E_∞,s is the
adaptive kernel's blur."""

from __future__ import annotations

import dataclasses

import numpy as np

from volcaustics.approx.splat import record_sigma, splats_from_arrays
from volcaustics.reference.oracle import exact_photon_records
from volcaustics.reports.experiment.exact import exact_photons, photons_from_records, pixel_footprint, subset_images
from volcaustics.scenes.formats import STATUS_COLLIDED

# E_∞ and E_∞,s: docs/decisions.md "Exact steps and the small kernel"
EXACT_STEPS = 128            # E_∞: < 0.1% of the power alive after them on every built-in
SMALL_SUPERSAMPLE = 4        # E_∞,s: splatted at 4× and box-averaged (the reference's pixel filter)
SMALL_KERNEL_FINE_PIXELS = 0.6  # E_∞,s kernel σ in fine pixels (0.15 pixel): aliasing ≈ 0.2%
SUBSET_BATCHES = 8           # paired photon subsets per seed of A and the E images: the decomposition's noise


def small_radius(scene, p) -> float:
    return SMALL_KERNEL_FINE_PIXELS * pixel_footprint(scene.camera, p.height * SMALL_SUPERSAMPLE)


def _paired_kernels(collided: np.ndarray, sigma: np.ndarray | None):
    """For splat = adaptive, a function giving exact photons (``ExactPhotons``) the
    kernels the approximation gave them: the kernel of the same photon's collision at the
    same step of A (``collided``, kernels ``sigma``), else (A's photon did not collide
    there: another path, or a step beyond A's) the median of A's kernels. For splat =
    fixed, the photons' splats as they are (splat_radius)."""
    if sigma is None:
        return lambda photons: photons.splats
    order = np.lexsort((collided["step"], collided["photon"]))
    keys = collided["photon"][order].astype(np.int64) << 16 | collided["step"][order].astype(np.int64)
    sorted_sigma, fallback = sigma[order], np.float32(np.median(sigma)) if len(sigma) else np.float32(0)

    def kernels(photons):
        wanted = photons.photon.astype(np.int64) << 16 | photons.step.astype(np.int64)
        at = np.clip(np.searchsorted(keys, wanted), 0, max(len(keys) - 1, 0))
        found = (keys[at] == wanted) if len(keys) else np.zeros(len(wanted), bool)
        splats = photons.splats.copy()
        splats["dir"][:, 3] = np.where(found, sorted_sigma[at] if len(keys) else fallback, fallback)
        return splats

    return kernels


def exact_images(scene, p, frames, replays, seeds, renderer, oracle) -> dict:
    """Per seed, SUBSET_BATCHES paired subset images (``reports.experiment.exact.subset_images``)
    of A, E_k, E_∞ (A's Fresnel), E_∞ (stochastic) and E_∞,s; all seeds' batches
    concatenated (batch j of every image: the same emission texels of one seed)."""
    out = {name: [] for name in ("approx", "exact_steps", "exact_all_same", "exact_all", "exact_all_small")}
    alive = {}
    small = dataclasses.replace(p, splat_radius=small_radius(scene, p))

    def batches(photons_or_rows, params, supersample=1):
        return subset_images(renderer, photons_or_rows[0], photons_or_rows[1], p.photon_res, SUBSET_BATCHES, params,
                             scene, supersample=supersample)

    for frame, replay, seed in zip(frames, replays, seeds):
        ps = dataclasses.replace(p, seed=seed)
        first = frame.records[0]
        collided = np.concatenate([r[r["status"] == STATUS_COLLIDED] for r in frame.records])
        sigma = record_sigma(collided, p)
        out["approx"].append(batches((splats_from_arrays(collided["end"], collided["direction"], collided["power"],
                                                         sigma), collided["photon"]), ps))
        kernels = _paired_kernels(collided, sigma)
        e_k = photons_from_records(replay, first, ps, steps=p.steps, fresnel=p.fresnel)
        out["exact_steps"].append(batches((kernels(e_k), e_k.photon), ps))
        records = exact_photon_records(scene, first, steps=EXACT_STEPS, seed=seed, fresnel=p.fresnel, oracle=oracle)
        same = photons_from_records(records, first, ps, steps=EXACT_STEPS, fresnel=p.fresnel)
        out["exact_all_same"].append(batches((kernels(same), same.photon), ps))
        everything = same
        if p.fresnel != "stochastic":
            everything = exact_photons(scene, ps, steps=EXACT_STEPS, fresnel="stochastic", renderer=renderer,
                                       oracle=oracle)
        out["exact_all"].append(batches((kernels(everything), everything.photon), ps))
        out["exact_all_small"].append(batches((everything.splats, everything.photon),
                                              dataclasses.replace(small, seed=seed), SMALL_SUPERSAMPLE))
        for fresnel, photons in {p.fresnel: same, "stochastic": everything}.items():
            alive.setdefault(fresnel, []).append(photons.alive_fraction)
    result = {name: np.concatenate(images) for name, images in out.items()}
    return {"batches": result, "alive": alive, "small_radius": small.splat_radius}
