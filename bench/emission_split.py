"""What splitting each photon at its first surface would buy the preset beams, emulated: the
frame of photons that all reflect there at R of their power plus the frame of photons that
all refract at 1 − R (the renderer control EMISSION_FRESNEL), the later steps as the
preset's, against the preset's own frames: one frame's caustic relMSE over the compared
pixels (glass left out, as the metrics do) and the mean image's, on the report's
reference; and the predicted cost of both, as the paper configuration's multiple (the
split's counts are the two frames' less the preset's: the light maps, the G-buffer and
the emission are drawn once).

    .venv/bin/python bench/emission_split.py SCENE [--seeds 24] [--photon-res N]

SCENE: a built-in name or a scene file (scenes/heldout/dense_forward.toml). Without
--photon-res, the preset's photon_res matched to the paper's cost (``approx.cost_match``).
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from volcaustics.approx.controls import CONTROLS
from volcaustics.approx.cost import frame_cost
from volcaustics.approx.cost_match import with_auto_photon_res
from volcaustics.approx.cost_model import predicted_frames, weight_sets
from volcaustics.approx.params import QUICK, preset
from volcaustics.approx.renderer import Renderer
from volcaustics.reference.render import render_reference
from volcaustics.reports.measuring.results.sizing import REPORT_REFERENCE, sized
from volcaustics.scenes import resolve_scene

WAYS = {"preset": {}, "reflect": {"EMISSION_FRESNEL": 1}, "refract": {"EMISSION_FRESNEL": 2}}
assert all(set(c) <= set(CONTROLS) for c in WAYS.values())


def _costs(scene, params) -> dict:
    """Predicted frame time / the paper configuration's, per weight set, for the preset and
    the split (seed 0's counts)."""
    sets = weight_sets()
    counts = {}
    for way, controls in WAYS.items():
        frame = Renderer(scene, controls=controls).render(scene, params, keep_records=True)
        counts[way] = frame_cost(frame.records, params.resolved(scene), frame.work)
    split = {k: counts["reflect"][k] + counts["refract"][k] - v if isinstance(v, (int, float)) else v
             for k, v in counts["preset"].items()}
    paper = Renderer(scene).render(scene, QUICK, keep_records=True)
    base = predicted_frames(frame_cost(paper.records, QUICK.resolved(scene), paper.work), QUICK.resolved(scene), sets)
    return {label: {k: v / base[k] for k, v in predicted_frames(c, params.resolved(scene), sets).items()}
            for label, c in (("preset", counts["preset"]), ("split", split))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--photon-res", type=int, default=None)
    args = ap.parse_args()
    scene = resolve_scene(args.scene)
    params = preset("beams")
    params = (dataclasses.replace(params, photon_res=args.photon_res) if args.photon_res
              else with_auto_photon_res(args.scene, params, "beams", given=False))
    ref = render_reference(scene, sized(REPORT_REFERENCE, scene, params), progress=False)
    keep = ref.mean["mask_specular"][..., 0] < 0.5
    frames = {way: [] for way in WAYS}
    for way, controls in WAYS.items():
        renderer = Renderer(scene, controls=controls)
        for seed in range(args.seeds):
            frame = renderer.render(scene, dataclasses.replace(params, seed=1000 + seed), keep_records=False)
            keep &= frame.images["mask_specular"][..., 0] < 0.5
            frames[way].append(frame.images["caustic"].astype(np.float64))
    mask = keep[..., None]
    R = ref.mean["caustic"].astype(np.float64) * mask
    energy = float((R * R).sum())
    costs = _costs(scene, params)
    print(f"{scene.name}: preset beams at photon_res {params.photon_res}, {args.seeds} seeds, reference "
          f"{R.shape[1]}x{R.shape[0]}; relMSE over the compared pixels")
    print("| frames | one frame: mean ± SE | median | worst | mean image | energy / R | predicted cost / paper |")
    print("|---|---|---|---|---|---|---|")
    for label, stack in (("preset", np.stack(frames["preset"])),
                         ("split", np.stack(frames["reflect"]) + np.stack(frames["refract"]))):
        stack = stack * mask
        err = ((stack - R) ** 2).reshape(len(stack), -1).sum(1) / energy
        mean = ((stack.mean(0) - R) ** 2).sum() / energy
        cost = ", ".join(f"{k} {v:.3f}" for k, v in costs[label].items())
        se = err.std(ddof=1) / np.sqrt(len(err))
        print(f"| {label} | {100 * err.mean():.1f}% ± {100 * se:.1f} | {100 * np.median(err):.1f}% | "
              f"{100 * err.max():.1f}% | {100 * mean:.1f}% | {stack.sum() / len(stack) / R.sum():.3f} | {cost} |")


if __name__ == "__main__":
    main()
