"""The results an accuracy report shows, gathered (``volcaustics report``).

Per scene: its experiment at the gate's preset and seeds, measured through the runner
(``reports.measuring.runner``: references rendered to the report's noise targets, results in
the store the gate shares, with the images a report shows), then the gate's checks on
it in lenient mode (``reports.studies.gate.verdict``: what cannot be checked is a note on the
page, not an error). With a sweep store, its consolidated tables. Everything is read
back from the stores, so a report drawn from a cold run and one drawn from a warm run
see the same data. ``reports.presenting.page`` draws from what :func:`run_report` gathers.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, cast

from volcaustics.experiment.point_checks import measured_settings
from volcaustics.experiment.timing import Clock
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.results.scene_result import SceneResult
from volcaustics.reports.presenting.page.page_write import write_report
from volcaustics.reports.presenting.page.report_document import DOCUMENT_FIELDS, STUDY_FIELDS, ReportDocument
from volcaustics.reports.presenting.page.report_summary import report_summary
from volcaustics.reports.presenting.report.sweep_store import ReportError
from volcaustics.reports.studies.gate.regression import load_baseline
from volcaustics.reports.studies.gate.verdict import scene_verdict
from volcaustics.reports.studies.registry import reported, resolve
from volcaustics.reports.studies.study import Gathered
from volcaustics.scenes import SceneError, resolve_scene

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.reports.studies.study import ReportInput


def collect_scenes(names: Sequence[str], params: ApproxParams, *, seeds: int, reference_settings: ReferenceSettings,
                   measurement: MeasurementSettings, budgets: dict, baseline: dict | None = None,
                   progress: bool = True, clock: Clock | None = None) -> list:
    """Every scene's result (measured or from the store), with the gate's verdicts.

    Parameters
    ----------
    names : SCENE arguments (built-in names or scene files).
    params : ``approx.ApproxParams`` of every experiment (unresolved: each scene's
        camera size where unset).
    seeds : frames per experiment (seeds params.seed …).
    reference_settings : ``reference.settings.ReferenceSettings``, sized per scene.
    measurement : ``experiment.measurement.MeasurementSettings``.
    budgets : ``reports.studies.gate.budgets.load_budgets``'s result; scenes without budgets get none.
    baseline : ``reports.studies.gate.regression.load_baseline``'s result, for the regression test.
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
                             images=("views",), parallel=True, progress=progress)
    with clock.stage("gate"):
        return [_scene_result(name, result, budgets, baseline) for name, result in zip(names, run.results)]


def budgets_key(name: str, budgets: dict) -> str | None:
    """The key of SCENE argument ``name`` in ``budgets`` (``load_budgets``): the key as written,
    a built-in's name, or the entry whose scene file (relative to the budgets file) is the
    file ``name`` names, however spelt; the gate's baseline holds its entry under that key."""
    if name in budgets["scenes"]:
        return name
    if not os.path.isfile(name):
        return None
    for key, arg in budgets.get("scene_args", {}).items():
        if os.path.isfile(arg) and os.path.samefile(arg, name):
            return key
    return None


def _scene_result(name, result, budgets: dict, baseline: dict | None) -> SceneResult:
    out = SceneResult(name=name, key=result.key, experiment=result.experiment, tables=result.tables, views=result.views,
                      measured=result.measured)
    key = budgets_key(name, budgets)
    if key is None:
        out.gate_note = f"no budgets for {name} in {budgets['path']}"
        return out
    verdict = scene_verdict(key, result, budgets["scenes"][key], baseline, strict=False)
    out.budgeted, out.checks, out.gate_note = True, verdict.checks, "; ".join(verdict.notes)
    return out


def run_report(out_dir: str, names: Sequence[str], *, overrides: dict, seeds: int | None, seed: int,
               reference_settings: ReferenceSettings, budgets: dict, measurement: MeasurementSettings | None = None,
               baseline_dir: str | None = None, studies: Mapping[str, Sequence[str]] | None = None,
               progress: bool = True) -> ReportDocument:
    """Gather every scene's results and the studies' outputs, then draw the report into
    ``out_dir`` (``page.write``). Returns the report's document (its ``summary.json``, typed).

    The approximation's parameters are the budgets' preset with ``overrides``; the
    seeds ``seed`` … ``seed + seeds − 1`` (``seeds`` default: the budgets'); the
    measurement settings ``measurement`` (default: the budgets' ``[measurement]``).
    ``studies``: study name → the values given to its report option
    (``reports.studies.registry.reported``: ``sweep`` → [DIR], ``animate`` → [DIR, …],
    ``compare`` → [NAME=DIR, …], ``frames`` → [DIR]), each read by the study's ``gather``
    into its field of the document before anything is measured."""
    clock = Clock()
    params, seeds = measured_settings(budgets["preset"], overrides, seeds=budgets["seeds"] if seeds is None else seeds,
                                      seed=seed, min_seeds=1, why="intervals need 4")
    gathered = gather_studies(studies or {}, names)      # bad input fails before anything renders
    baseline = load_baseline(baseline_dir) if baseline_dir else None
    measurement = measurement or budgets["measurement"]
    results = collect_scenes(names, params, seeds=seeds, reference_settings=reference_settings,
                             measurement=measurement, budgets=budgets,
                             baseline=baseline, progress=progress, clock=clock)
    document = report_summary(results, params=params, seeds=seeds, reference_settings=reference_settings,
                              measurement=measurement,
                              budgets=budgets, baseline_dir=baseline_dir, clock=clock.seconds)
    parts = {field: part.document for field, part in gathered.items()}  # a new study's field: the document's extra
    document = dataclasses.replace(document, **{f: v for f, v in parts.items() if f in STUDY_FIELDS},
                                   extra={f: v for f, v in parts.items() if f not in STUDY_FIELDS})
    sweep = gathered.get("sweep")
    return write_report(out_dir, results, document, None if sweep is None else sweep.tables, progress=progress,
                        started=clock.started, media={field: part.media for field, part in gathered.items()})


def gather_studies(values: Mapping[str, Sequence[str]], names: Sequence[str]) -> dict[str, Gathered]:
    """Each reported study given values, read by its ``gather``: field of the document →
    what it gathered, in the registry's order; a study the registry does not know is a
    ValueError (a caller's mistake, not the user's)."""
    known = {s.name: s for s in reported()}
    unknown = sorted(set(values) - set(known))
    if unknown:
        raise ValueError(f"no reported study named {', '.join(unknown)}: one of {', '.join(known)}")
    taken = sorted(f for s in known.values() if (f := cast("ReportInput", s.report).field) in DOCUMENT_FIELDS
                   and f not in STUDY_FIELDS)
    if taken:
        raise ValueError(f"study fields {', '.join(taken)}: the report's document has such fields of its own")
    out: dict[str, Gathered] = {}
    for name, study in known.items():
        given = list(values.get(name) or ())
        if given:
            report = cast("ReportInput", study.report)
            out[report.field] = resolve(report.gather)(given, names)
    return out
