"""The frame check (``volcaustics frames``, ``make frames``): per scene, the paper's
configuration against ``--preset best`` and ``--preset beams`` (the paper's competitors:
best with photon beams; both with photon_res matched to the paper's frame cost on that
scene, ``reports.measuring.cost_match``), each without and with OIDN
(``denoise``: the same seeds, so the same frames, denoised), by one frame's caustic
error and the seeds' mean's debiased error. The scenes are the built-ins and the
held-out scenes (``scenes/heldout``), which no search saw: a configuration that wins
only where it was chosen shows it here.

Every scene is resolved and checked before any work (a bad name, a medium without a
caustic, two files of one scene name are refused at once). Every point is measured by
the runner (``reports.measuring.runner``) into a result store in ``DIR`` (``DIR/points/KEY/``,
its ``summary.json`` and tables, ``reports.measuring.results.store``), one scene at a time,
and its row is read from there: an interrupted check resumes where it stopped, and a
point edited or damaged since is measured again. A scene whose reference has no caustic
over the compared pixels is refused after its first points, naming it.

Output (``DIR``): ``frames.parquet`` (one row per scene, configuration and denoiser;
``group``: builtin, media, heldout or yours) and ``frames.json`` (its manifest, ``kind`` frames,
strict JSON, recording the table's SHA-256 and its own), written as one set
(``infra.storage.atomic_set``). The report's "One frame" section reads them
(``report --frames DIR``), refusing a table or manifest that does not match.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import pandas as pd

from volcaustics.approx.params import preset
from volcaustics.experiment.measurement import MeasurementSettings
from volcaustics.experiment.point_checks import checked_settings
from volcaustics.experiment.sizing import REPORT_REFERENCE
from volcaustics.experiment.versions import code_version
from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import atomic_set, document_sha256, file_sha256, read_json_object
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.cost_match import with_auto_values
from volcaustics.reports.measuring.results.store import Store
from volcaustics.reports.measuring.results.tables import plain
from volcaustics.reports.studies.sweep.study_limits import FRAME_CHECK_SEEDS
from volcaustics.scenes import resolve_scene
from volcaustics.scenes.catalogue import BUILTIN_NAMES, HELDOUT_NAMES, MEDIA_NAMES, heldout_path, named_path

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.experiment.result import Experiment
    from volcaustics.scenes.model import Scene

CONFIGS = ("paper", "best", "beams")  # the quick preset (the paper's method), the presets best and beams
DENOISERS = ("none", "oidn")
FRAMES_FILE, MANIFEST = "frames.parquet", "frames.json"
KIND = "frames"                   # frames.json's "kind" (reports.measuring.results.output_folders.FOLDER_MARKERS)
SCHEMA = 2                        # frames.json's "schema": its shape, checked when read back (2: sealed)
MANIFEST_SEAL = "frames_sha256"   # frames.json's field holding the SHA-256 of the rest of it
POINTS = "points"                 # DIR/points/: the result store's points (reports.measuring.results.store)
FRAMES_REFERENCE = REPORT_REFERENCE  # every point's reference: the report's
GROUPS = ("builtin", "media", "heldout", "yours")  # a scene's group: a built-in, a media scene, held out, yours


def default_scenes() -> list:
    """Every built-in, then every held-out scene (by path)."""
    return [*BUILTIN_NAMES, *(heldout_path(name) for name in HELDOUT_NAMES)]


def config_params(config: str, scene_arg: str, scene: Scene | None = None) -> ApproxParams:
    """The parameters of ``config`` on ``scene_arg`` (``scene``: it resolved; best,
    beams: photon_res matched)."""
    if config == "paper":
        return preset("quick")
    return with_auto_values(scene_arg, preset(config), config, given=False, scene=scene)


def checked_scenes(scenes: Iterable[str], seeds: int) -> list:
    """(argument, scene, group) per scene, every one resolved and checked before any
    work: InputError for a bad name or file, a medium without a caustic, a frame that
    cannot run, or two arguments of one scene name (their rows would collide)."""
    # by the file itself: an installed package may name the held-out files through links
    heldout = {os.path.realpath(heldout_path(name)) for name in HELDOUT_NAMES}
    media = {os.path.realpath(str(named_path(name))) for name in MEDIA_NAMES}  # by name or by path
    seen: dict
    out, seen = [], {}
    for arg in scenes:
        scene = resolve_scene(arg)
        checked_settings(scene, preset("quick"), seeds)
        if scene.name in seen:
            raise InputError(f"frames: {seen[scene.name]} and {arg} are both scene {scene.name!r}: a scene is "
                             f"measured once (rename one, its [scene] name)")
        seen[scene.name] = arg
        group = ("builtin" if arg in BUILTIN_NAMES else "media" if os.path.realpath(named_path(arg) or arg) in media
                 else "heldout" if os.path.realpath(arg) in heldout else "yours")
        out.append((arg, scene, group))
    return out


def run_frames(scenes: Sequence[str], out_dir: str, *, seeds: int = FRAME_CHECK_SEEDS,
               progress: bool = True) -> pd.DataFrame:
    """Measure every (scene, configuration, denoiser) the store in ``out_dir`` does not
    hold yet; write and return the table."""
    checked = checked_scenes(scenes, seeds)
    denoisers = usable_denoisers(progress)
    store, rows, t0 = Store(out_dir), [], time.perf_counter()
    for scene_arg, scene, group in checked:
        wanted = [(config, denoiser, dataclasses.replace(matched, denoise=denoiser))  # the denoiser beside the cost
                  for config in CONFIGS for matched in (config_params(config, scene_arg, scene),)
                  for denoiser in denoisers]
        points = [runner.Point(scene_arg, params, seeds, resolved=scene) for *_, params in wanted]
        results = []
        for batch in (points[:1], points[1:]):  # the first alone: a scene without a caustic stops there
            results += runner.measure(batch, store, reference_settings=FRAMES_REFERENCE, policy="continue",
                                      measurement=MeasurementSettings(scope="gate"), progress=progress).results
            if not math.isfinite(results[0].experiment.metric("frame_relative_mse").debiased):
                raise InputError(f"frames: {scene_arg}: the reference's caustic is zero over the compared "
                                 f"pixels, so there is no caustic error to measure (does the light's beam "
                                 f"reach the glass, and the glass's light the medium?)")
        identity = {"scene": scene.name, "heldout": group == "heldout", "group": group}
        rows += [{**identity, "config": config, "denoise": denoiser, **_row(point.experiment)}
                 for (config, denoiser, _), point in zip(wanted, results)]
    table = with_ratios(pd.DataFrame(rows))
    manifest = {"kind": KIND, "schema": SCHEMA, "scenes": list(scenes), "seeds": seeds, "configs": list(CONFIGS),
                "denoisers": list(denoisers), "code_version": code_version(), "seconds": time.perf_counter() - t0,
                "verdict": verdict(table)}
    write_frames(out_dir, table, manifest)
    return table


def write_frames(out_dir: str, table: pd.DataFrame, manifest: dict) -> None:
    """``DIR/frames.parquet`` and, last, ``DIR/frames.json`` as one set
    (``infra.storage.atomic_set``: an interrupted write leaves the previous set): the
    manifest strict JSON (NaN as null), recording the table's SHA-256 (``files``) and
    its own (MANIFEST_SEAL), which :func:`load_frames` checks.

    Parameters
    ----------
    out_dir : the frame check's folder (created if missing).
    table : the table (one row per scene, configuration and denoiser).
    manifest : its manifest, without ``files`` and the seal (added here).

    Example
    -------
    >>> write_frames("runs/frames", table, {"kind": KIND, "schema": SCHEMA, "verdict": verdict(table)})
    """
    os.makedirs(out_dir, exist_ok=True)
    with atomic_set([os.path.join(out_dir, FRAMES_FILE), os.path.join(out_dir, MANIFEST)]) as (table_tmp, tmp):
        table.to_parquet(table_tmp, index=False)
        doc = plain({**manifest, "files": {FRAMES_FILE: file_sha256(table_tmp)}})
        doc[MANIFEST_SEAL] = document_sha256(doc, MANIFEST_SEAL)
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(doc, fh, indent=1, allow_nan=False)


def usable_denoisers(say: bool = True) -> tuple:
    """DENOISERS less OIDN where its binding cannot load here (said on stderr): the frame
    check's rows without a denoiser are its verdict, OIDN's are beside it."""
    from volcaustics.approx.denoise import unavailable

    reason = unavailable()
    if reason is None:
        return DENOISERS
    if say:
        import sys

        print(f"frames: note: {reason}; measuring without the denoiser rows", file=sys.stderr)
    return tuple(d for d in DENOISERS if d != "oidn")


def _row(e: Experiment) -> dict:
    """A point's numbers: photon_res, cost, one frame's and the mean's caustic errors, times
    (NaN where not measured: a stage not timed, no denoiser)."""
    frame, mean = e.metric("frame_relative_mse"), e.metric("relative_mse")
    return {"photon_res": e.params.photon_res, "frame_cost": e.cost.counted,
            **{f"predicted_{name}": value for name, value in e.cost.predicted.items()},
            "frame_relmse": frame.debiased, "frame_relmse_se": frame.standard_error,
            "relmse_debiased": mean.debiased, "relmse_se": mean.standard_error,
            "hdr_flip": e.metric("hdr_flip").value, "frame_s": e.timings.get("frame_wall", math.nan),
            "denoise_s": e.timings.get("denoise", math.nan), "denoised_pixels": e.cost.denoised_pixels}


def with_ratios(table: pd.DataFrame) -> pd.DataFrame:
    """Per row its cost, time, one-frame and debiased errors against its scene's paper
    configuration without a denoiser: ``counted_ratio`` (the counted total), ``cost_ratio``
    (the largest predicted ratio over the cost model's weight sets, ``predicted_<set>``
    columns), ``time_ratio`` (measured frame time, each point's own timed frames)."""
    table = table.copy()
    paper = table[(table["config"] == "paper") & (table["denoise"] == "none")].set_index("scene")
    table["counted_ratio"] = table["frame_cost"] / table["scene"].map(paper["frame_cost"])
    predicted = [c for c in table.columns if c.startswith("predicted_")]
    ratios = [table[c] / table["scene"].map(paper[c]) for c in predicted]
    table["cost_ratio"] = pd.concat(ratios, axis=1).max(axis=1) if ratios else table["counted_ratio"]
    table["time_ratio"] = (table["frame_s"] / table["scene"].map(paper["frame_s"]) if "frame_s" in table
                           else float("nan"))
    table["frame_ratio"] = table["frame_relmse"] / table["scene"].map(paper["frame_relmse"])
    table["relmse_ratio"] = table["relmse_debiased"].clip(lower=0.0) / table["scene"].map(paper["relmse_debiased"])
    return table


GOAL = 0.5  # the goal: one frame's caustic relMSE at most half the paper configuration's on every scene


def verdict(table: pd.DataFrame) -> dict:
    """best without a denoiser against the goal, on the built-ins, the held-out scenes
    and the user's scenes apart (GROUPS); the same with OIDN beside; beams' worst ratios
    the same way (keys ``beams_…``) beside."""
    out = {"goal": GOAL}
    groups = table["group"] if "group" in table else table["heldout"].map({True: "heldout", False: "builtin"})
    for config, prefix in (("best", ""), ("beams", "beams_")):
        for denoiser in DENOISERS:
            rows_of = table[(table["config"] == config) & (table["denoise"] == denoiser)]
            for group in GROUPS:
                rows = rows_of[groups[rows_of.index] == group]
                if len(rows):
                    out[f"{prefix}{denoiser}_{group}_worst_frame_ratio"] = float(rows["frame_ratio"].max())
                    out[f"{prefix}{denoiser}_{group}_worst_cost_ratio"] = float(rows["cost_ratio"].max())
                    out[f"{prefix}{denoiser}_{group}_worst_time_ratio"] = float(rows["time_ratio"].max())
    plain = table[(table["config"] == "best") & (table["denoise"] == "none")]
    out["met"] = bool(len(plain) and (plain["frame_ratio"] <= GOAL).all() and (plain["cost_ratio"] <= 1.01).all())
    return out


# the columns the report's "One frame" section reads (reports.presenting.page.frame_check_section)
READ_COLUMNS = ("scene", "heldout", "config", "denoise", "photon_res", "cost_ratio", "frame_relmse", "frame_relmse_se",
                "frame_ratio", "relmse_debiased", "relmse_se", "relmse_ratio")


def load_frames(folder: str) -> tuple:
    """(table, manifest) of a frame check's folder, checked against the shape this
    module writes (``kind``, ``schema``, a verdict with a numeric goal, the manifest's
    SHA-256 of itself and of the table, the columns the report reads), before anything
    else is done with them; FileNotFoundError, or ValueError naming the file, field and
    what was expected (another run's table beside the manifest is refused)."""
    path = os.path.join(folder, MANIFEST)
    manifest = read_json_object(path)
    if manifest.get("kind") != KIND:
        raise ValueError(f"{path}: kind = {manifest.get('kind')!r}: expected {KIND!r} (written by volcaustics frames)")
    if type(manifest.get("schema")) is not int or manifest["schema"] != SCHEMA:
        raise ValueError(f"{path}: schema = {manifest.get('schema')!r}: expected {SCHEMA}")
    v = manifest.get("verdict")
    if not isinstance(v, dict) or isinstance(v.get("goal"), bool) or not isinstance(v.get("goal"), (int, float)) \
            or not isinstance(v.get("met"), bool):
        raise ValueError(f"{path}: verdict = {v!r}: expected an object with a number goal and a true/false met")
    try:
        sealed = manifest.get(MANIFEST_SEAL) == document_sha256(manifest, MANIFEST_SEAL)
    except ValueError:  # NaN or inf: not strict JSON, so not as written
        sealed = False
    if not sealed:
        raise ValueError(f"{path}: does not match the SHA-256 it records of itself ({MANIFEST_SEAL}): edited or "
                         f"damaged since `volcaustics frames` wrote it")
    files = manifest.get("files")
    table_path = os.path.join(folder, FRAMES_FILE)
    if not isinstance(files, dict) or files.get(FRAMES_FILE) != file_sha256(table_path):
        raise ValueError(f"{table_path}: does not match the SHA-256 its {MANIFEST} records (another run's table, "
                         f"or edited or damaged since `volcaustics frames` wrote the pair)")
    table = pd.read_parquet(table_path)
    missing = [c for c in READ_COLUMNS if c not in table.columns]
    if missing:
        raise ValueError(f"{table_path}: no column {missing[0]!r}: not a frame check's table "
                         f"(another command's, or damaged)")
    return table, manifest
