"""The results an accuracy report shows, gathered (``volcaustics report``).

Per scene: its experiment at the gate's preset and seeds, measured through the runner
(``reports.runner``: references rendered to the report's noise targets, results in
the store the gate shares, with the images a report shows), then the gate's checks on
it in lenient mode (``reports.gate.verdict``: what cannot be checked is a note on the
page, not an error). With a sweep store, its consolidated tables. Everything is read
back from the stores, so a report drawn from a cold run and one drawn from a warm run
see the same data. This is the only part of the report that measures
(``page.summary`` and ``page.write`` draw from what it returns).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import pandas as pd

from volcaustics.approx.params import PARAMS, ApproxParams
from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import file_sha256, read_json_object, special_file_kind
from volcaustics.reports import runner
from volcaustics.reports.animate.read import load_animation
from volcaustics.reports.compare.read import comparison_folders, load_comparison
from volcaustics.reports.core.store import POINT_COLUMNS, document_sha256
from volcaustics.reports.core.timing import Clock
from volcaustics.reports.core.versions import code_version
from volcaustics.reports.experiment.settings import measured_settings
from volcaustics.reports.gate.regression import load_baseline
from volcaustics.reports.gate.verdict import scene_verdict
from volcaustics.reports.page.animations import animation_rows
from volcaustics.reports.page.external import comparison_images, comparison_row
from volcaustics.reports.page.frames import frames_rows
from volcaustics.reports.page.summary import report_summary
from volcaustics.reports.page.write import write_report
from volcaustics.reports.sweep.frames import load_frames
from volcaustics.reports.sweep.run import MANIFEST_SEAL
from volcaustics.scenes import SceneError, resolve_scene


class ReportError(InputError):
    """Bad report input (a scene, a sweep store, an output folder): exit 2; the
    message names the value and the fix."""


@dataclass
class SceneResult:
    """One scene's experiment as the store holds it, and the gate's verdicts on it."""

    name: str
    key: str
    summary: dict            # the experiment's summary.json (reports.experiment)
    tables: dict             # "segments", "photons", "images" → pandas DataFrame
    views: dict              # reports.experiment.summary.VIEWS name → H×W×3 float32
    checks: list = field(default_factory=list)   # reports.gate.budgets.Check
    gate_note: str = ""      # why the gate could not check this scene (no budgets, a GateError)
    budgeted: bool = False   # the budgets have this scene
    measured: bool = False   # measured in this run (False: from the store)


@dataclass
class SweepTables:
    """A sweep store's consolidated tables and the parameters it varied."""

    folder: str
    tables: dict             # "segments", "photons", "images", "points" → DataFrame
    varied: list
    spec: dict
    notes: list = field(default_factory=list)  # what differs from this code (shown on the page)


def collect_scenes(names, params, *, seeds: int, reference_settings, measurement, budgets: dict,
                   baseline: dict | None = None, progress: bool = True, clock: Clock | None = None) -> list:
    """Every scene's result (measured or from the store), with the gate's verdicts.

    Parameters
    ----------
    names : SCENE arguments (built-in names or scene files).
    params : ``approx.ApproxParams`` of every experiment (unresolved: each scene's
        camera size where unset).
    seeds : frames per experiment (seeds params.seed …).
    reference_settings : ``reference.settings.ReferenceSettings``, sized per scene.
    measurement : ``reports.experiment.measurement.MeasurementSettings``.
    budgets : ``reports.gate.budgets.load_budgets``'s result; scenes without budgets get none.
    baseline : ``reports.gate.regression.load_baseline``'s result, for the regression test.
    clock : receives the seconds of each stage.
    """
    clock = clock or Clock()
    for name in names:
        try:
            resolve_scene(name)
        except SceneError as exc:
            raise ReportError(f"--scenes: {exc}") from None
    with clock.stage("experiments"):
        run = runner.measure([runner.Point(name, params, seeds) for name in names], runner.results_store(),
                             reference_settings=reference_settings, measurement=measurement, policy="continue",
                             views=True, parallel=True, progress=progress)
    with clock.stage("gate"):
        return [_scene_result(name, result, budgets, baseline) for name, result in zip(names, run.results)]


def _scene_result(name, result, budgets: dict, baseline: dict | None) -> SceneResult:
    scene = result.summary["scene"]
    out = SceneResult(name=name, key=result.key, summary=result.summary, tables=result.tables, views=result.views,
                      measured=result.measured)
    limits = budgets["scenes"].get(scene)
    if limits is None:
        out.gate_note = f"no budgets for {scene} in {budgets['path']}"
        return out
    verdict = scene_verdict(scene, result, limits, baseline, strict=False)
    out.budgeted, out.checks, out.gate_note = True, verdict.checks, "; ".join(verdict.notes)
    return out


def load_sweep(folder: str) -> SweepTables:
    """A sweep store's consolidated tables (``volcaustics sweep -o DIR`` wrote them)."""
    try:
        doc = read_json_object(os.path.join(folder, "sweep.json"))
    except FileNotFoundError:
        raise ReportError(f"--sweep {folder}: no sweep.json: not a sweep store (run `volcaustics sweep ... -o "
                          f"{folder}` first)") from None
    except ValueError as exc:
        raise ReportError(f"--sweep: {exc}: rerun the sweep") from None
    spec = doc.get("spec")
    if not isinstance(spec, dict) or not isinstance(spec.get("vary"), dict):
        raise ReportError(f"--sweep {folder}: sweep.json has no spec with a \"vary\" table: rerun the sweep")
    names = ("segments", "photons", "images", "points")
    if isinstance(doc.get("files"), dict) and "best.parquet" in doc["files"]:
        names += ("best",)  # the best-configuration search's table (reports.sweep.best)
    hashes = _check_hashes(folder, doc, names)
    tables = {name: _sweep_table(folder, name) for name in names}
    if len(tables["points"]) == 0:
        raise ReportError(f"--sweep {folder}: the sweep holds no finished point")
    notes = hashes + _check_schema(folder, tables["points"])
    return SweepTables(folder=folder, tables=tables, varied=list(spec["vary"]), spec=spec, notes=notes)


def _check_hashes(folder: str, doc: dict, names) -> list:
    """Check sweep.json against the SHA-256 it records of itself, and the tables
    ``names`` against those it records (``files``): ReportError naming a file edited or
    damaged since the sweep wrote it. A store from
    before sweep.json recorded them is drawn unchecked: returns the note the page shows."""
    if MANIFEST_SEAL in doc and doc[MANIFEST_SEAL] != document_sha256(doc, MANIFEST_SEAL):
        raise ReportError(f"--sweep {folder}: sweep.json does not match the SHA-256 it records of itself (edited "
                          f"or damaged since the sweep wrote it): rerun the sweep (`volcaustics sweep SPEC -o "
                          f"{folder}` keeps every undamaged point)")
    files = doc.get("files")
    if not isinstance(files, dict):
        return ["its sweep.json records no SHA-256 of its tables (written by an older volcaustics), so they are "
                "shown unchecked: rerun the sweep to record them"]
    for name in names:
        path = os.path.join(folder, f"{name}.parquet")
        try:
            digest = file_sha256(path)
        except FileNotFoundError:
            continue  # _sweep_table says what is missing
        except OSError as exc:
            raise ReportError(f"--sweep {folder}: {name}.parquet unreadable ({exc}): rerun the sweep") from None
        if files.get(f"{name}.parquet") != digest:
            raise ReportError(f"--sweep {folder}: {name}.parquet does not match the SHA-256 its sweep.json records "
                              f"(edited or damaged since the sweep wrote it): rerun the sweep (`volcaustics sweep "
                              f"SPEC -o {folder}` keeps every undamaged point)")
    return []


def _check_schema(folder: str, points: pd.DataFrame) -> list:
    """Check a store's points table against this code's (``store.POINT_COLUMNS`` and the
    parameter table); returns the notes the page shows. A column of numbers missing: an
    older store, refused (ReportError naming them). A parameter missing: the store
    predates it, so its points ran the parameter's default, which is filled in and noted.
    Points of another code version: noted (their numbers may differ from this code's)."""
    versions = sorted({str(v) for v in points["code_version"]}) if "code_version" in points else ["unknown"]
    missing = [c for c in POINT_COLUMNS if c not in points]
    if missing:
        raise ReportError(f"--sweep {folder}: its points table lacks {', '.join(missing)}: written by an older "
                          f"volcaustics (code version {', '.join(versions)}); rerun the sweep with this code "
                          f"(`volcaustics sweep SPEC -o {folder}` keeps nothing it cannot use)")
    notes = []
    defaults = ApproxParams()
    absent = [p.name for p in PARAMS if p.name not in points]
    for name in absent:
        points[name] = getattr(defaults, name)
    if absent:
        notes.append(f"the store predates the parameter{'s' if len(absent) > 1 else ''} {', '.join(absent)}: its "
                     f"points ran the default ({', '.join(f'{n} = {getattr(defaults, n)}' for n in absent)})")
    current = code_version()
    if versions != [current]:
        notes.append(f"measured by code version {', '.join(versions)}, not this code's {current}: its numbers may "
                     f"differ from what this code measures; rerun the sweep to refresh them")
    return notes


def _sweep_table(folder: str, name: str) -> pd.DataFrame:
    path = os.path.join(folder, f"{name}.parquet")
    special = special_file_kind(path)
    if special:  # never opened: a FIFO would block
        raise ReportError(f"--sweep {folder}: {name}.parquet is {special}: rerun the sweep")
    try:
        return pd.read_parquet(path)
    except FileNotFoundError:
        raise ReportError(f"--sweep {folder}: no {name}.parquet: the sweep has not finished a point "
                          f"(rerun it to consolidate)") from None
    except Exception as exc:  # pyarrow raises its own types for a damaged file
        raise ReportError(f"--sweep {folder}: {name}.parquet unreadable ({exc}): rerun the sweep") from None


def run_report(out_dir: str, names, *, overrides: dict, seeds: int | None, seed: int, reference_settings,
               budgets: dict, measurement=None, baseline_dir: str | None = None, sweep_dir: str | None = None,
               animation_dirs=(), comparisons=(), frames_dir: str | None = None, progress: bool = True) -> dict:
    """Gather every scene's results and the sweep's, then draw the report into
    ``out_dir`` (``page.write``). Returns the report's summary.

    The approximation's parameters are the budgets' preset with ``overrides``; the
    seeds ``seed`` … ``seed + seeds − 1`` (``seeds`` default: the budgets'); the
    measurement settings ``measurement`` (default: the budgets' ``[measurement]``).
    ``comparisons``: (NAME, DIR) pairs of ``report --compare``, each DIR a compare
    output or a folder of them, shown beside the approximation on their scenes."""
    clock = Clock()
    params, seeds = measured_settings(budgets["preset"], overrides, seeds=budgets["seeds"] if seeds is None else seeds,
                                      seed=seed, min_seeds=1, why="intervals need 4")
    sweep = load_sweep(sweep_dir) if sweep_dir else None      # bad input fails before anything renders
    animations = [load_animation(folder) for folder in animation_dirs or ()]
    frames = _load_frames(frames_dir) if frames_dir else None
    compared = load_comparisons(comparisons, names)
    baseline = load_baseline(baseline_dir) if baseline_dir else None
    measurement = measurement or budgets["measurement"]
    results = collect_scenes(names, params, seeds=seeds, reference_settings=reference_settings,
                             measurement=measurement, budgets=budgets,
                             baseline=baseline, progress=progress, clock=clock)
    summary = report_summary(results, params=params, seeds=seeds, reference_settings=reference_settings,
                             measurement=measurement,
                             budgets=budgets, baseline_dir=baseline_dir, sweep=sweep, clock=clock.seconds)
    summary["animations"] = animation_rows(animations)
    summary["comparisons"] = [row for row, _ in compared]
    summary["frames"] = None if frames is None else {"rows": frames_rows(frames[0]), "verdict": frames[1]["verdict"],
                                                     "folder": os.path.abspath(frames_dir)}
    return write_report(out_dir, results, summary, sweep, progress=progress, started=clock.started,
                        animation_media=[a["media"] for a in animations],
                        comparison_media=[comparison_images(row, views) for row, views in compared])


def _load_frames(folder: str) -> tuple:
    """A frame check's (table, manifest); ReportError naming the fix."""
    try:
        return load_frames(folder)
    except (OSError, ValueError, KeyError) as exc:
        raise ReportError(f"--frames {folder}: not a readable frame check ({exc}): run `volcaustics frames -o "
                          f"{folder}`") from None


def load_comparisons(pairs, names) -> list:
    """(row, views) of every comparison ``report --compare NAME=DIR`` names, each of a
    scene the report shows (by content: the scene hash), in the order given."""
    shown = {resolve_scene(name).scene_hash(): name for name in names}
    out, seen = [], set()
    for name, folder in pairs:
        for path in comparison_folders(folder, f"--compare {name}="):
            loaded = load_comparison(path, f"--compare {name}=")
            s = loaded["summary"]
            if s["scene_hash"] not in shown:
                raise ReportError(f"--compare {name}={path}: compares {s['scene']!r} (hash {s['scene_hash'][:12]}), "
                                  f"which this report does not show (or shows changed): add it to --scenes, or "
                                  f"rerun compare on the scene as it is now")
            if (name, s["scene_hash"]) in seen:
                raise ReportError(f"--compare {name}={path}: a second comparison of {name} on {s['scene']}: give "
                                  f"each renderer one folder per scene")
            seen.add((name, s["scene_hash"]))
            row = comparison_row(loaded, name)
            row["scene"], row["anchor"] = shown[s["scene_hash"]], f"compare-{len(out)}"
            out.append((row, loaded["views"]))
    return out

