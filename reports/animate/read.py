"""Reading an ``animate -o DIR`` folder back (the report's "Over time" section, the
gate's flicker budgets): its summary and its media as data URIs."""

from __future__ import annotations

import base64
import os

from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import read_json_object
from volcaustics.reports.core.summaries import check_schema

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
        raise InputError(f"{option} {folder}: summary.json is not an animation's (kind {summary.get('kind')!r}): "
                    f"{fix}")
    check_schema(summary, "animation", f"{option} {folder}", fix)
    media = {}
    video = summary.get("video") or {}
    for name, path in (("web", video.get("web")), ("plot", "timeseries.png")):
        file = os.path.join(folder, str(path))
        try:
            with open(file, "rb") as fh:
                data = fh.read()
        except OSError as exc:
            raise InputError(f"{option} {folder}: {path} unreadable ({exc.strerror or exc}): {fix}") from None
        ext = os.path.splitext(file)[1].lstrip(".").lower()
        media[name] = f"data:{MIME.get(ext, 'image/png')};base64," + base64.b64encode(data).decode("ascii")
    return {"folder": os.path.abspath(folder), "summary": summary, "media": media}
