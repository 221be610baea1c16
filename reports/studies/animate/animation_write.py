"""``animate -o DIR``: the tables (Parquet and CSV), the videos, the plot and, last,
``summary.json``, written as one set (``infra.storage.atomic_set``)."""

from __future__ import annotations

import json
import os
from typing import TYPE_CHECKING

from volcaustics.infra.storage import atomic_set
from volcaustics.reports.measuring.results.tables import plain, table
from volcaustics.reports.studies.animate.media import plot_png, video_frames, web_format, write_mp4, write_web

if TYPE_CHECKING:
    from volcaustics.reports.studies.animate.animation_frames import AnimationFrames

TABLE_FILES = ("frames", "temporal")


def output_files(fmt: str | None = None) -> tuple:
    """What ``animate -o DIR`` writes, summary.json (the manifest) last."""
    return (*(f"{name}.{ext}" for name in TABLE_FILES for ext in ("parquet", "csv")), "animation.mp4",
            f"animation.{fmt or web_format()}", "timeseries.png", "summary.json")


def write_animation(run: AnimationFrames, frames: list, temporal: list, summary: dict, out_dir: str) -> dict:
    """Write the set into ``out_dir``; returns name → path. The video shows the first seed
    mode's first chain."""
    fmt = web_format()
    paths = {name: os.path.join(out_dir, name) for name in output_files(fmt)}
    pictures = video_frames(run, run.modes[0])
    fps = run.scene.animation.fps
    with atomic_set(list(paths.values())) as temps:
        tmp = dict(zip(paths, temps))
        for name, rows in (("frames", frames), ("temporal", temporal)):
            data = table(rows)
            data.to_parquet(tmp[f"{name}.parquet"], index=False)
            data.to_csv(tmp[f"{name}.csv"], index=False)
        write_mp4(tmp["animation.mp4"], pictures, fps)
        write_web(tmp[f"animation.{fmt}"], pictures, fps, fmt)
        with open(tmp["timeseries.png"], "wb") as fh:
            fh.write(plot_png(run, frames, temporal))
        doc = {**summary, "video": {"mode": run.modes[0], "chain": 0, "frames": len(pictures), "fps": fps,
                                    "web": f"animation.{fmt}",
                                    "panels": "approximation | reference | per-pixel relative MSE (combined)"},
               "outputs": {k: os.path.abspath(v) for k, v in paths.items()}}
        with open(tmp["summary.json"], "w", encoding="utf-8") as fh:
            fh.write(json.dumps(plain(doc), indent=2, allow_nan=False))
    return paths
