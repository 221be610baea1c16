"""`volcaustics reference`: the ground truth of one scene, from the cache or
rendered, copied to OUT.exr (mean and ``_var`` layers, manifest in the header),
OUT.png (tonemapped combined) and OUT.json (the manifest). The cache files are
copied as they are (atomically), so a cached call costs little more than
Python's start-up."""

from __future__ import annotations

import json
import os
import shutil

from scenes.storage import atomic_path, atomic_write_text


def _copy(src: str, dst: str) -> None:
    with atomic_path(dst) as tmp:
        shutil.copyfile(src, tmp)


def run_reference(scene, settings, out: str, *, force: bool = False) -> dict:
    from reference.render import render_reference

    result = render_reference(scene, settings, force=force)
    base = out[:-4] if out.lower().endswith(".exr") else out
    paths = {"exr": base + ".exr", "png": base + ".png", "json": base + ".json"}
    _copy(result.exr_path, paths["exr"])
    _copy(result.png_path, paths["png"])
    summary = {**result.manifest, "outputs": {k: os.path.abspath(v) for k, v in paths.items()}}
    atomic_write_text(paths["json"], json.dumps(summary, indent=2, default=float))
    return summary
