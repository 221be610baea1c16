"""An animation's files: the tables (Parquet and CSV), the videos and the plot, written into
the sealed set the result store keeps (``results.sealed_sets``), whose ``summary.json``
is written last; ``animate -o DIR`` receives a copy of the set."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from volcaustics.reports.measuring.results.tables import plain, table
from volcaustics.reports.studies.animate.media import plot_png, video_frames, web_format, write_mp4, write_web

if TYPE_CHECKING:
    from volcaustics.reports.studies.animate.animation_frames import AnimationFrames

TABLE_FILES = ("frames", "temporal")


def output_files(fmt: str | None = None) -> tuple:
    """What ``animate -o DIR`` writes, summary.json (the manifest) last."""
    return (*(f"{name}.{ext}" for name in TABLE_FILES for ext in ("parquet", "csv")), "animation.mp4",
            f"animation.{fmt or web_format()}", "timeseries.png", "summary.json")


def write_animation(run: AnimationFrames, frames: list, temporal: list, summary: dict, folder: str) -> dict:
    """Write the set's files into the fresh ``folder`` (a sealed set's temporary folder,
    ``results.sealed_sets.write_set``, put in place whole); returns the summary with the
    video's description. The video shows the first seed mode's first chain."""
    fmt = web_format()
    paths = {name: os.path.join(folder, name) for name in output_files(fmt) if name != "summary.json"}
    pictures = video_frames(run, run.modes[0])
    fps = run.scene.animation.fps
    for name, rows in (("frames", frames), ("temporal", temporal)):
        data = table(rows)
        data.to_parquet(paths[f"{name}.parquet"], index=False)
        data.to_csv(paths[f"{name}.csv"], index=False)
    write_mp4(paths["animation.mp4"], pictures, fps)
    write_web(paths[f"animation.{fmt}"], pictures, fps, fmt)
    with open(paths["timeseries.png"], "wb") as fh:
        fh.write(plot_png(run, frames, temporal))
    return plain({**summary, "video": {"mode": run.modes[0], "chain": 0, "frames": len(pictures), "fps": fps,
                                       "web": f"animation.{fmt}",
                                       "panels": "approximation | reference | per-pixel relative MSE (combined)"}})
