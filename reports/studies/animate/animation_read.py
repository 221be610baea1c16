"""Reading an ``animate -o DIR`` folder back (the report's "Over time" section, the
gate's flicker budgets): its summary and its media as data URIs."""

from __future__ import annotations

import base64
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, NoReturn

from volcaustics.experiment.result import from_stored, to_stored
from volcaustics.experiment.summaries import check_schema
from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import read_json_object
from volcaustics.reports.measuring.results.sealed_sets import damaged_set

KIND = "animation"  # summary.json "kind" of an animate output folder
MIME = {"webp": "image/webp", "gif": "image/gif"}


FLICKER_NUMBERS = ("flicker", "flicker_se", "flicker_systematic", "flicker_approx_noise", "flicker_max",
                   "energy_jitter_rms")


@dataclass(frozen=True)
class Flicker:
    """One component over time in one seed mode (docs/over-time.md): the mean ``flicker``
    over the frame pairs ± ``flicker_se``, its systematic part and the frames' own noise
    in it, the worst pair, the RMS of the energy ratio's jitter, per image metric the mean
    and worst of its per-frame series (``series``: metric → (mean, worst)), the pairs
    measured and how many frames the chains' mean trails the references (``lag_frames``).
    NaN where not measured."""

    flicker: float
    flicker_se: float
    flicker_systematic: float
    flicker_approx_noise: float
    flicker_max: float
    energy_jitter_rms: float
    series: Mapping[str, tuple[float, float]]
    pairs: int
    lag_frames: float

    @classmethod
    def from_json(cls, data: Mapping) -> Flicker:
        metrics = [k[:-len("_mean")] for k in data if k.endswith("_mean")]
        series = {m: (from_stored(data.get(f"{m}_mean")), from_stored(data.get(f"{m}_worst"))) for m in metrics}
        numbers = {k: from_stored(data.get(k)) for k in FLICKER_NUMBERS}
        return cls(**numbers, series=series, pairs=int(data.get("pairs") or 0),
                   lag_frames=from_stored(data.get("lag_frames")))

    def to_json(self) -> dict:
        """The stored form (NaN as None)."""
        return {**{k: to_stored(getattr(self, k)) for k in FLICKER_NUMBERS},
                **{f"{m}_mean": to_stored(mean) for m, (mean, _) in self.series.items()},
                **{f"{m}_worst": to_stored(worst) for m, (_, worst) in self.series.items()},
                "pairs": self.pairs, "lag_frames": to_stored(self.lag_frames)}


@dataclass(frozen=True)
class MeasuredAnimation:
    """An animation ``animate`` measured, read at its boundary (callers read attributes):
    the ``scene``, the ``frames`` measured at ``fps``, its ``seed_modes`` and ``chains``,
    per seed mode and component its :class:`Flicker`, what it took (``seconds``), its
    video files, the code that measured it and why the perceptual video metric was not
    measured. ``folder``: where it was read from ("" for one measured in this process);
    ``media``: its video and plot as data URIs (empty unless read)."""

    scene: str
    frames: list
    fps: float
    seed_modes: tuple[str, ...]
    chains: int
    metrics: Mapping[str, Mapping[str, Flicker]]
    seconds: Mapping[str, Any]
    video: Mapping[str, Any]
    code_version: str | None
    perceptual_video_metric: Mapping[str, Any] | None
    folder: str = ""
    media: Mapping[str, str] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_summary(cls, s: Mapping, folder: str = "", media: Mapping | None = None) -> MeasuredAnimation:
        """The animation a summary (checked by :func:`check_animation_shape`) describes."""
        metrics = {mode: {c: Flicker.from_json(m) for c, m in s["metrics"][mode].items()} for mode in s["metrics"]}
        return cls(s["scene"], s["frames"], s["animation"]["fps"], tuple(s["seed_modes"]), int(s["chains"]), metrics,
                   dict(s["seconds"]), dict(s.get("video") or {}), s.get("code_version"),
                   s.get("perceptual_video_metric"), folder, dict(media or {}))


def load_animation(folder: str, option: str = "--animation") -> MeasuredAnimation:
    """An animate output folder, with its media as data URIs; InputError (exit 2)
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
    damage = damaged_set(folder, summary)
    if damage:
        raise InputError(f"{option} {folder}: {damage}: run `volcaustics animate SCENE -o {folder}` again")
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
    return MeasuredAnimation.from_summary(summary, os.path.abspath(folder), media)


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
    for key, kind in (("chains", int), ("seconds", dict), ("video", dict)):
        if isinstance(summary.get(key), bool) or not isinstance(summary.get(key), kind):
            bad(key, f"a{'n integer' if kind is int else ' table'}")
    metrics: dict = summary["metrics"]
    for mode in modes:
        table = metrics.get(mode)
        if not isinstance(table, dict) or not table or not all(isinstance(v, dict) for v in table.values()):
            bad(f"metrics.{mode}", "a table of metrics per component for this seed mode")
