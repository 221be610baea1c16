"""The display frame's test configurations, small enough for llvmpipe (64×64 on sphere1):
the paper's points, best (density splats), beams (Fresnel splits: the beams preset's
fresnel_splits = 2) and beams of balanced widths, each at a photon_res that keeps a frame under a second."""

from __future__ import annotations

from volcaustics.approx.params import preset

SCENE = "sphere1"
CONFIGS = {"paper": preset("paper", width=64, height=64, photon_res=64, light_res=64),
           "best": preset("best", photon_res=48, width=64, height=64, light_res=64),
           "beams": preset("beams", photon_res=32, width=64, height=64, light_res=64),
           # balanced beam widths: a pilot, the balance pass and a second write per step, all on the GPU
           "balanced": preset("beams", photon_res=32, width=64, height=64, light_res=64, beam_width="balanced")}
