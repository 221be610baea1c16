"""The exact caustic images of the decomposition, as paired photon subsets: A, E_k,
E_∞ (A's Fresnel), E_∞ (stochastic) and E_∞,s (small kernel, supersampled)."""

from __future__ import annotations

import dataclasses

import numpy as np

from volcaustics.approx.splat import splats_from_arrays
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
        out["approx"].append(batches((splats_from_arrays(collided["end"], collided["direction"], collided["power"]),
                                      collided["photon"]), ps))
        e_k = photons_from_records(replay, first, ps, steps=p.steps, fresnel=p.fresnel)
        out["exact_steps"].append(batches((e_k.splats, e_k.photon), ps))
        records = exact_photon_records(scene, first, steps=EXACT_STEPS, seed=seed, fresnel=p.fresnel, oracle=oracle)
        same = photons_from_records(records, first, ps, steps=EXACT_STEPS, fresnel=p.fresnel)
        out["exact_all_same"].append(batches((same.splats, same.photon), ps))
        everything = same
        if p.fresnel != "stochastic":
            everything = exact_photons(scene, ps, steps=EXACT_STEPS, fresnel="stochastic", renderer=renderer,
                                       oracle=oracle)
        out["exact_all"].append(batches((everything.splats, everything.photon), ps))
        out["exact_all_small"].append(batches((everything.splats, everything.photon),
                                              dataclasses.replace(small, seed=seed), SMALL_SUPERSAMPLE))
        for fresnel, photons in {p.fresnel: same, "stochastic": everything}.items():
            alive.setdefault(fresnel, []).append(photons.alive_fraction)
    result = {name: np.concatenate(images) for name, images in out.items()}
    return {"batches": result, "alive": alive, "small_radius": small.splat_radius}
