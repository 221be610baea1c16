"""`volcaustics reference`: the ground truth of one scene, from the cache or
rendered, copied to OUT.exr (mean and ``_var`` layers), OUT.png (tonemapped
combined) and OUT.json (the manifest). Atomic writes."""

from __future__ import annotations

import json
import os

from scenes.imageio import write_exr
from scenes.storage import atomic_write_text

from .imageio import write_png


def run_reference(scene, settings, out: str, *, force: bool = False) -> dict:
    from reference.render import render_reference

    result = render_reference(scene, settings, force=force)
    base = out[:-4] if out.lower().endswith(".exr") else out
    paths = {"exr": base + ".exr", "png": base + ".png", "json": base + ".json"}
    layers = dict(result.mean)
    layers.update({f"{k}_var": v for k, v in result.var.items()})
    write_exr(paths["exr"], layers, {"volcaustics_scene": scene.name, "volcaustics_scene_hash": scene.scene_hash(),
                                     "volcaustics_renderer": "reference",
                                     "volcaustics_manifest": json.dumps(result.manifest, default=float)})
    write_png(paths["png"], result.mean["combined"])
    summary = {**result.manifest, "outputs": {k: os.path.abspath(v) for k, v in paths.items()}}
    atomic_write_text(paths["json"], json.dumps(summary, indent=2, default=float))
    return summary
