"""Reading ``compare -o DIR`` folders back (``report --compare``, ``gate --compare``):
each checked against the SHA-256s its summary records."""

from __future__ import annotations

import os

from volcaustics.experiment.summaries import check_schema
from volcaustics.infra.errors import InputError
from volcaustics.infra.imageio import read_exr
from volcaustics.infra.storage import document_sha256, file_sha256, read_json_object
from volcaustics.reports.studies.compare.comparison_run import KIND
from volcaustics.reports.studies.compare.comparison_write import DATA_FILES, SEAL, SUMMARY


def parse_named(text: str, option: str) -> tuple:
    """``NAME=DIR`` → (NAME, DIR); InputError naming the option for anything else."""
    name, sep, folder = text.partition("=")
    name, folder = name.strip(), folder.strip()
    if not sep or not name or not folder:
        raise InputError(f"{option} {text!r}: expected NAME=DIR (a name for the renderer, a compare output folder or "
                    f"a folder of them)")
    if not all(c.isalnum() or c in "_-." for c in name):
        raise InputError(f"{option} {text!r}: the name {name!r} may hold letters, digits, '_', '-' and '.' only")
    return name, folder


def comparison_folders(folder: str, option: str) -> list:
    """``folder`` itself when it is a compare output, else its subfolders that are (one
    per scene), sorted; InputError when there is none."""
    if os.path.isfile(os.path.join(folder, SUMMARY)):
        return [folder]
    if not os.path.isdir(folder):
        raise InputError(f"{option} {folder}: no such folder: "
                         f"run `volcaustics compare SCENE IMAGE.exr -o {folder}` first")
    found = sorted(os.path.join(folder, d) for d in os.listdir(folder)
                   if os.path.isfile(os.path.join(folder, d, SUMMARY)))
    if not found:
        raise InputError(f"{option} {folder}: holds no summary.json, nor do its subfolders: run `volcaustics compare "
                    f"SCENE IMAGE.exr -o {folder}` first")
    return found


def load_comparison(folder: str, option: str = "--compare", views: bool = True) -> dict:
    """A compare output folder: {"folder", "summary", "views"} (views: name → H×W×3
    float32, when ``views``); InputError naming the folder and the fix when it is not one,
    was edited, or is damaged."""
    fix = f"run `volcaustics compare SCENE IMAGE.exr -o {folder}` again"
    try:
        summary = read_json_object(os.path.join(folder, SUMMARY))
    except (OSError, ValueError) as exc:
        raise InputError(f"{option} {folder}: no readable {SUMMARY} ({exc}): {fix}") from None
    if summary.get("kind") != KIND or not isinstance(summary.get("images"), dict):
        raise InputError(f"{option} {folder}: {SUMMARY} is not a comparison's (kind {summary.get('kind')!r}): {fix}")
    check_schema(summary, "comparison", f"{option} {folder}", fix)
    if summary.get(SEAL) != _seal(summary):
        raise InputError(f"{option} {folder}: {SUMMARY} does not match the SHA-256 it records of itself (edited or "
                    f"damaged): {fix}")
    for field, ok in (("scene", isinstance(summary.get("scene"), str) and summary["scene"]),
                      ("scene_hash", isinstance(summary.get("scene_hash"), str) and summary["scene_hash"]),
                      ("components", isinstance(summary.get("components"), list) and summary["components"]),
                      ("images", summary["images"] and all(isinstance(v, dict) for v in summary["images"].values()))):
        if not ok:  # what the report and the gate read: refused here, not as a KeyError after measuring
            raise InputError(f"{option} {folder}: {SUMMARY}: {field} = {summary.get(field)!r}: expected what "
                             f"compare writes there: {fix}")
    files = summary.get("files") or {}
    for name in DATA_FILES:
        try:
            digest = file_sha256(os.path.join(folder, name))
        except OSError as exc:
            raise InputError(f"{option} {folder}: {name} unreadable ({exc.strerror or exc}): {fix}") from None
        if files.get(name) != digest:
            raise InputError(f"{option} {folder}: {name} does not match the SHA-256 {SUMMARY} records (edited or "
                        f"damaged): {fix}")
    out = {"folder": os.path.abspath(folder), "summary": summary, "views": {}}
    if views:
        out["views"], _ = read_exr(os.path.join(folder, "views.exr"))
    return out


def _seal(summary: dict) -> str | None:
    try:
        return document_sha256(summary, SEAL)
    except ValueError:  # NaN in it: not what write_comparison wrote
        return None
