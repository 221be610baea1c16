"""`volcaustics reference`: the ground truth of one scene, from the cache or
rendered, copied to OUT.exr (mean and ``_var`` layers, manifest in the header),
OUT.png (tonemapped combined) and OUT.json (the manifest), as one unit. The cache
files are copied as they are, so a cached call costs little more than
Python's start-up."""

from __future__ import annotations

import json
import os
import shutil
from typing import TYPE_CHECKING

from volcaustics.infra.storage import atomic_set
from volcaustics.reference.render import render_reference
from volcaustics.reference.served import judged
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.presenting.exports.output_paths import render_outputs

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene


def run_reference(scene: Scene, settings: ReferenceSettings | None, out: str, *, force: bool = False) -> dict:
    """The reference of ``scene`` at ``settings`` copied to ``out`` and its siblings; the
    manifest written to OUT.json, with ``served_to``: the entry judged against this
    request (``reference.served.judged``: an entry rendered for another request can serve it)."""
    result = render_reference(scene, settings, force=force)
    request = (settings or ReferenceSettings()).resolved(scene)
    paths = render_outputs(out, {"png": ".png", "json": ".json"})
    try:
        return _copy_out(result, request, paths)
    except FileNotFoundError:
        if os.path.exists(result.exr_path) and os.path.exists(result.png_path):
            raise
        # another process continued the entry meanwhile (its files replaced): serve that one
        return _copy_out(render_reference(scene, settings), request, paths)


def _copy_out(result, request: ReferenceSettings, paths: dict) -> dict:
    """Copy the entry's files and write its manifest to ``paths``, as one unit."""
    summary = {**result.manifest, "served_to": judged(result.manifest, request),
               "outputs": {k: os.path.abspath(v) for k, v in paths.items()}}
    with atomic_set([paths["exr"], paths["png"], paths["json"]]) as (exr, png, manifest):
        shutil.copyfile(result.exr_path, exr)
        shutil.copyfile(result.png_path, png)
        with open(manifest, "w") as fh:
            fh.write(json.dumps(summary, indent=2, default=float))
    return summary
