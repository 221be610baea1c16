"""Reading an ``animate -o DIR`` folder back (the report's "Over time" section, the
gate's flicker budgets): its summary and its media as data URIs."""

from __future__ import annotations

import base64
import os
from typing import Any, NoReturn

from volcaustics.experiment.summaries import check_schema
from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import read_json_object

KIND = "animation"  # summary.json "kind" of an animate output folder
MIME = {"webp": "image/webp", "gif": "image/gif"}


def load_animation(folder: str, option: str = "--animation") -> dict:
    """An animate output folder's summary and its media as data URIs; InputError (exit 2)
    naming the folder and the fix when it is not one, or one of another schema."""
    fix = f"run `volcaustics animate SCENE -o {folder}` first"
    try:
        summary = read_json_object(os.path.join(folder, "summary.json"))
    except (OSError, ValueError) as exc:
        raise InputError(f"{option} {folder}: no readable summary.json ({exc}): {fix}") from None
    if summary.get("kind") != KIND or not isinstance(summary.get("metrics"), dict):
        what = (f"of kind {summary.get('kind')!r}" if summary.get("kind") != KIND else "without its metrics table")
        raise InputError(f"{option} {folder}: summary.json is not an animation's ({what}): {fix}")
    check_schema(summary, "animation", f"{option} {folder}", fix)
    check_animation_shape(summary, f"{option} {folder}: summary.json", fix)
    media = {}
    video = summary.get("video") or {}
    for name, path in (("web", video.get("web")), ("plot", "timeseries.png")):
        if not isinstance(path, str) or not path:
            raise InputError(f"{option} {folder}: summary.json names no {name} video (video.{name} = {path!r}): {fix}")
        file = os.path.join(folder, path)
        try:
            with open(file, "rb") as fh:
                data = fh.read()
        except OSError as exc:
            raise InputError(f"{option} {folder}: {path} unreadable ({exc.strerror or exc}): {fix}") from None
        ext = os.path.splitext(file)[1].lstrip(".").lower()
        media[name] = f"data:{MIME.get(ext, 'image/png')};base64," + base64.b64encode(data).decode("ascii")
    return {"folder": os.path.abspath(folder), "summary": summary, "media": media}


def check_animation_shape(summary: dict, where: str, fix: str) -> None:
    """InputError naming the field unless ``summary`` has every field the report and the
    gate read, of its type: scene, frames, animation.fps, seed_modes (a non-empty list),
    chains, seconds, video, and per seed mode a table of metrics per component."""
    def bad(field: str, expected: str) -> NoReturn:
        value: Any = summary
        for part in field.split("."):
            value = value.get(part) if isinstance(value, dict) else None
        raise InputError(f"{where}: {field} = {value!r}: expected {expected}: {fix}")

    if not isinstance(summary.get("scene"), str) or not summary["scene"]:
        bad("scene", "a scene name")
    if isinstance(summary.get("frames"), bool) or not isinstance(summary.get("frames"), (int, list)):
        bad("frames", "the frames measured")
    fps = (summary.get("animation") or {}).get("fps") if isinstance(summary.get("animation"), dict) else None
    if isinstance(fps, bool) or not isinstance(fps, (int, float)):
        bad("animation.fps", "a number")
    modes = summary.get("seed_modes")
    if not isinstance(modes, list) or not modes or not all(isinstance(m, str) for m in modes):
        bad("seed_modes", "a non-empty list of seed modes")
    for field, kind in (("chains", int), ("seconds", dict), ("video", dict)):
        if isinstance(summary.get(field), bool) or not isinstance(summary.get(field), kind):
            bad(field, f"a{'n integer' if kind is int else ' table'}")
    metrics: dict = summary["metrics"]
    for mode in modes:
        table = metrics.get(mode)
        if not isinstance(table, dict) or not table or not all(isinstance(v, dict) for v in table.values()):
            bad(f"metrics.{mode}", "a table of metrics per component for this seed mode")
