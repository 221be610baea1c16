"""The results an accuracy report shows, gathered (``volcaustics report``).

Per scene: its reference (cached, else rendered to the report's noise targets), its
experiment (``reports.experiment``; the gate's preset and seeds) from the report's
result store — a ``reports.store.Store`` under ``$VOLCAUSTICS_CACHE/report-results``
whose points also keep the images a report shows (``views.exr``) — measured only when
the store does not hold it, then the gate's checks on it (``reports.gate``: the
budgets and, with a baseline, the regression test). With a sweep store, its
consolidated tables. Everything is read back from the stores, so a report drawn from
a cold run and one drawn from a warm run see the same data.

This is the only part of the report that renders or measures (:mod:`reports.report`
draws from what it returns).
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass, field

STORE_NAME = "report-results"


class ReportError(ValueError):
    """Bad report input (a scene, a sweep store, an output folder): exit 2; the
    message names the value and the fix."""


@dataclass
class SceneResult:
    """One scene's experiment as the store holds it, and the gate's verdicts on it."""

    name: str
    key: str
    summary: dict            # the experiment's summary.json (reports.experiment)
    tables: dict             # "segments", "photons", "images" → pandas DataFrame
    views: dict              # reports.experiment.VIEWS name → H×W×3 float32
    checks: list = field(default_factory=list)   # reports.gate.Check
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


def store_dir() -> str:
    from volcaustics.scenes.storage import cache_dir

    return cache_dir(STORE_NAME)


def _stage(names, desc: str, progress: bool):
    from tqdm import tqdm

    return tqdm(names, desc=desc, unit="scene", disable=not progress)


def collect_scenes(names, params, *, seeds: int, reference_settings, budgets: dict, baseline: dict | None = None,
                   progress: bool = True, clock: dict | None = None) -> list:
    """Every scene's result (references first, then the experiments, then the gate).

    Parameters
    ----------
    names : SCENE arguments (built-in names or scene files).
    params : ``approx.ApproxParams`` of every experiment (unresolved: each scene's
        camera size where unset).
    seeds : frames per experiment (seeds params.seed …).
    reference_settings : ``reference.settings.ReferenceSettings``, sized per scene.
    budgets : ``reports.gate.load_budgets``'s result; scenes without budgets get none.
    baseline : ``reports.gate.load_baseline``'s result, for the regression test.
    clock : receives the seconds of each stage.
    """
    from volcaustics.reference.render import render_reference
    from volcaustics.scenes import SceneError, resolve_scene

    from volcaustics.reports.core.store import Store

    clock = {} if clock is None else clock
    scenes = {}
    for name in names:
        try:
            scenes[name] = resolve_scene(name)
        except SceneError as exc:
            raise ReportError(f"--scenes: {exc}") from None
    t = time.perf_counter()
    references = {}
    for name in _stage(names, "references", progress):
        p = params.resolved(scenes[name])
        settings = dataclasses.replace(reference_settings, width=p.width, height=p.height)
        references[name] = render_reference(scenes[name], settings, progress=progress)
    clock["references"] = time.perf_counter() - t

    t = time.perf_counter()
    store = Store(store_dir())
    store.clean_stale()
    results = []
    for name in _stage(names, "experiments", progress):
        results.append(_scene_result(store, scenes[name], name, params, seeds, references[name], progress))
    clock["experiments"] = time.perf_counter() - t

    t = time.perf_counter()
    for result in _stage(results, "gate", progress):
        _gate(result, budgets, baseline)
    clock["gate"] = time.perf_counter() - t
    return results


def _scene_result(store, scene, name, params, seeds, reference, progress: bool = False) -> SceneResult:
    import pandas as pd

    from volcaustics.reports.experiment.run import run_experiment
    from volcaustics.reports.core.store import TABLES, key_document, point_key

    document = key_document(scene, params, seeds, reference)
    key = point_key(document)
    measured = store.status(key, views=True) != "done"
    if measured:
        store.remove_damaged(key, views=True)
        experiment = run_experiment(scene, params, seeds=seeds, reference=reference, progress=progress)
        store.write_point(key, document, experiment, views=True)
    summary = store.summary(key)
    if summary is None:
        raise ReportError(f"{store.point_dir(key)}: the result of {name} could not be read back after writing it")
    tables = {t: pd.read_parquet(os.path.join(store.point_dir(key), f"{t}.parquet")) for t in TABLES}
    return SceneResult(name=name, key=key, summary=summary, tables=tables, views=store.views(key), measured=measured)


class _Stored:
    """What ``reports.gate``'s checks read of an experiment, from the store."""

    def __init__(self, result: SceneResult):
        self.summary = result.summary
        from volcaustics.reports.core.store import rows_of

        self.segments = rows_of(result.tables["segments"])


def _gate(result: SceneResult, budgets: dict, baseline: dict | None) -> None:
    from volcaustics.reports.gate.run import GateError, baseline_entry, budget_checks, regression_check

    limits = budgets["scenes"].get(result.summary["scene"])
    if limits is None:
        result.gate_note = f"no budgets for {result.summary['scene']} in {budgets['path']}"
        return
    result.budgeted = True
    stored = _Stored(result)
    try:
        result.checks = budget_checks(result.name, limits, stored)
    except GateError as exc:
        result.gate_note = f"budgets not checked: {exc}"
    if baseline is None:
        return
    base = baseline["scenes"].get(result.summary["scene"])
    try:
        entry = baseline_entry(stored)
        if base is None:
            note = "the baseline has no entry for this scene: no regression test"
        elif base.get("reference_key") != entry["reference_key"]:
            note = "the baseline was measured against another reference: no regression test (update the baseline)"
        else:
            result.checks.append(regression_check(result.name, entry, base))
            return
    except GateError as exc:
        note = f"regression not tested: {exc}"
    result.gate_note = "; ".join(n for n in (result.gate_note, note) if n)


def load_sweep(folder: str) -> SweepTables:
    """A sweep store's consolidated tables (``volcaustics sweep -o DIR`` wrote them)."""
    import pandas as pd

    from volcaustics.scenes.storage import read_json_object, special_file_kind

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
    tables = {}
    for name in ("segments", "photons", "images", "points"):
        path = os.path.join(folder, f"{name}.parquet")
        special = special_file_kind(path)
        if special:  # never opened: a FIFO would block
            raise ReportError(f"--sweep {folder}: {name}.parquet is {special}: rerun the sweep")
        try:
            tables[name] = pd.read_parquet(path)
        except FileNotFoundError:
            raise ReportError(f"--sweep {folder}: no {name}.parquet: the sweep has not finished a point "
                              f"(rerun it to consolidate)") from None
        except Exception as exc:  # pyarrow raises its own types for a damaged file
            raise ReportError(f"--sweep {folder}: {name}.parquet unreadable ({exc}): rerun the sweep") from None
    if len(tables["points"]) == 0:
        raise ReportError(f"--sweep {folder}: the sweep holds no finished point")
    return SweepTables(folder=folder, tables=tables, varied=list(spec["vary"]), spec=spec)


def run_report(out_dir: str, names, *, overrides: dict, seeds: int | None, seed: int, reference_settings,
               budgets: dict, baseline_dir: str | None = None, sweep_dir: str | None = None,
               progress: bool = True) -> dict:
    """Gather every scene's results and the sweep's, then draw the report into
    ``out_dir`` (``reports.report``). Returns the report's summary.

    The approximation's parameters are the budgets' preset with ``overrides``; the
    seeds ``seed`` … ``seed + seeds − 1`` (``seeds`` default: the budgets')."""
    from volcaustics.reports.gate.run import load_baseline, measured_settings
    from volcaustics.reports.page.summary import report_summary, write_report

    t0 = time.perf_counter()
    params, seeds = measured_settings(budgets, overrides, seeds=seeds, seed=seed, min_seeds=1,
                                      why="intervals need 4")
    sweep = load_sweep(sweep_dir) if sweep_dir else None      # bad input fails before anything renders
    baseline = load_baseline(baseline_dir) if baseline_dir else None
    clock = {}
    results = collect_scenes(names, params, seeds=seeds, reference_settings=reference_settings, budgets=budgets,
                             baseline=baseline, progress=progress, clock=clock)
    summary = report_summary(results, params=params, seeds=seeds, reference_settings=reference_settings,
                             budgets=budgets, baseline_dir=baseline_dir, sweep=sweep, clock=clock)
    return write_report(out_dir, results, summary, sweep, progress=progress, started=t0)
