"""Reading ``compare -o DIR`` folders back (``report --compare``, ``gate --compare``):
each checked against the SHA-256s its summary records."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from volcaustics.experiment.result import Estimate, ImageMetric, find_estimate
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


@dataclass(frozen=True)
class ComparedRenderer:
    """Another renderer's images judged against the reference (a ``compare`` output, read
    at its boundary: callers read attributes): the ``renderer``'s name, the ``scene``
    (and its content hash), the images' size and count (``seeds``), the ``components``
    they hold, which ``mask`` the metrics used ("file" or "reference"), the reference's
    record as judged, every image metric, the warnings, the code that measured it and
    what each stage took (``seconds``). ``folder``: where it was read from ("" for one
    measured in this process); ``views``: name → H×W×3 float32 (empty unless read)."""

    renderer: str
    scene: str
    scene_hash: str
    width: int
    height: int
    seeds: int
    components: tuple[str, ...]
    mask: str
    reference: Mapping[str, Any]
    compared_pixels: int
    images: tuple[ImageMetric, ...]
    warnings: tuple[str, ...]
    code_version: str | None
    seconds: Mapping[str, float] | None
    folder: str = ""
    views: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_summary(cls, summary: Mapping, folder: str = "", views: Mapping | None = None) -> ComparedRenderer:
        """The comparison a summary.json (checked by :func:`load_comparison`) describes."""
        images = tuple(ImageMetric(c, m, Estimate.from_json(v)) for c, metrics in summary["images"].items()
                       for m, v in metrics.items() if isinstance(v, Mapping))
        return cls(str(summary.get("renderer", "")), summary["scene"], summary["scene_hash"], int(summary["width"]),
                   int(summary["height"]), int(summary["seeds"]), tuple(summary["components"]),
                   str(summary.get("mask", "")), dict(summary.get("reference") or {}),
                   int(summary.get("compared_pixels") or 0), images, tuple(summary.get("warnings") or ()),
                   summary.get("code_version"), summary.get("seconds"), folder, dict(views or {}))

    def find_metric(self, metric: str, component: str) -> Estimate | None:
        """One image metric, None where it was not measured."""
        return find_estimate(self.images, metric, component)

    def metric(self, metric: str, component: str) -> Estimate:
        """One image metric; KeyError naming it where it was not measured."""
        found = self.find_metric(metric, component)
        if found is None:
            raise KeyError(f"{self.renderer} on {self.scene}: no {component} {metric}")
        return found


def load_comparison(folder: str, option: str = "--compare", views: bool = True) -> ComparedRenderer:
    """A compare output folder (views: name → H×W×3 float32, when ``views``); InputError
    naming the folder and the fix when it is not one, was edited, or is damaged."""
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
    for key, ok in (("scene", isinstance(summary.get("scene"), str) and summary["scene"]),
                    ("scene_hash", isinstance(summary.get("scene_hash"), str) and summary["scene_hash"]),
                    ("components", isinstance(summary.get("components"), list) and summary["components"]),
                    ("images", summary["images"] and all(isinstance(v, dict) for v in summary["images"].values()))):
        if not ok:  # what the report and the gate read: refused here, not as a KeyError after measuring
            raise InputError(f"{option} {folder}: {SUMMARY}: {key} = {summary.get(key)!r}: expected what "
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
    return ComparedRenderer.from_summary(summary, os.path.abspath(folder),
                                         read_exr(os.path.join(folder, "views.exr"))[0] if views else None)


def _seal(summary: dict) -> str | None:
    try:
        return document_sha256(summary, SEAL)
    except ValueError:  # NaN in it: not what write_comparison wrote
        return None
