"""The configuration the shipped best search adopted (``make sweep-best``;
docs/decisions.md "The best-configuration search"): adaptive splats and emission,
stochastic Fresnel, 6 steps, 2 layers, splat_footprints 2, with the photon_res that
matched the paper configuration's frame cost on each built-in at the quick preset.
The closure checks (``bench/closure.py``, ``tests/reports/test_closure.py``) measure it
beside the paper's configuration."""

from __future__ import annotations

import dataclasses

ADOPTED = {"splat": "adaptive", "emission": "adaptive", "fresnel": "stochastic", "steps": 6, "layers": 2,
           "splat_footprints": 2.0}
ADOPTED_PHOTON_RES = {"two_spheres": 268, "sphere1": 236, "sphere2": 191, "refocus": 256, "bunny": 125,
                      "skull": 216, "feline": 104}


def adopted_params(base, scene: str):
    """``base`` (e.g. the quick preset) with the adopted configuration and ``scene``'s
    cost-matched photon_res (``base``'s for a scene the search did not see)."""
    return dataclasses.replace(base, **ADOPTED, photon_res=ADOPTED_PHOTON_RES.get(scene, base.photon_res))
