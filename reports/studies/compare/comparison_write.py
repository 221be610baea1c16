"""``compare -o DIR``: ``images.parquet`` and ``.csv``, ``views.exr`` (the renderer's
mean images, the reference's and the error maps), ``index.html`` (the renderer's page
section) and, last, ``summary.json``, which records every other file's SHA-256 and its
own (SEAL), written as one set."""

from __future__ import annotations

import json
import os
from typing import TYPE_CHECKING

from volcaustics.infra.imageio import write_exr
from volcaustics.infra.storage import atomic_set, document_sha256, file_sha256
from volcaustics.reports.measuring.results.tables import plain, table

if TYPE_CHECKING:
    from volcaustics.reports.studies.compare.comparison_run import Comparison

SUMMARY = "summary.json"
SEAL = "summary_sha256"   # summary.json's field holding the SHA-256 of the rest of it
DATA_FILES = ("images.parquet", "images.csv", "views.exr")
PAGE = "index.html"
OUTPUT_FILES = (*DATA_FILES, PAGE, SUMMARY)


def write_comparison(comparison: Comparison, out_dir: str, page: str) -> dict:
    """Write the comparison and its ``page`` (HTML text) into ``out_dir`` as one set
    (``infra.storage.atomic_set``: an interrupted write leaves the last complete set).
    Returns the paths."""
    os.makedirs(out_dir, exist_ok=True)
    paths = {name: os.path.join(out_dir, name) for name in OUTPUT_FILES}
    s = comparison.summary
    with atomic_set(list(paths.values())) as temps:
        tmp = dict(zip(paths, temps))
        frame = table(comparison.images)
        frame.to_parquet(tmp["images.parquet"], index=False)
        frame.to_csv(tmp["images.csv"], index=False)
        write_exr(tmp["views.exr"], comparison.views,
                  {"volcaustics_scene": s["scene"], "volcaustics_scene_hash": s["scene_hash"],
                   "volcaustics_renderer": f"compare views of {s['renderer']}"})
        with open(tmp[PAGE], "w", encoding="utf-8") as fh:
            fh.write(page)
        doc = plain({**s, "outputs": {k: os.path.abspath(v) for k, v in paths.items()},
                     "files": {name: file_sha256(tmp[name]) for name in (*DATA_FILES, PAGE)}})
        doc[SEAL] = document_sha256(doc, SEAL)
        with open(tmp[SUMMARY], "w", encoding="utf-8") as fh:
            fh.write(json.dumps(doc, indent=2, allow_nan=False))
    return paths
