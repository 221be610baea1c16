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
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, cast

from volcaustics.experiment.point_checks import measured_settings
from volcaustics.experiment.timing import Clock
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.results.scene_result import SceneResult
from volcaustics.reports.presenting.page.animations import animation_rows
from volcaustics.reports.presenting.page.external import comparison_images, comparison_row
from volcaustics.reports.presenting.page.frame_check_section import frames_rows
from volcaustics.reports.presenting.page.page_write import write_report
from volcaustics.reports.presenting.page.report_document import FramesSummary, ReportDocument
from volcaustics.reports.presenting.page.report_summary import report_summary
from volcaustics.reports.presenting.report.sweep_store import ReportError, load_sweep
from volcaustics.reports.studies.animate.animation_read import load_animation
from volcaustics.reports.studies.best.frame_check import load_frames
from volcaustics.reports.studies.compare.comparison_read import comparison_folders, load_comparison
from volcaustics.reports.studies.gate.regression import load_baseline
from volcaustics.reports.studies.gate.verdict import scene_verdict
from volcaustics.scenes import SceneError, resolve_scene

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.reference.settings import ReferenceSettings


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
               baseline_dir: str | None = None, sweep_dir: str | None = None, animation_dirs: Iterable[str] = (),
               comparisons: Iterable[tuple[str, str]] = (), frames_dir: str | None = None,
               progress: bool = True) -> ReportDocument:
    """Gather every scene's results and the sweep's, then draw the report into
    ``out_dir`` (``page.write``). Returns the report's document (its ``summary.json``, typed).

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
    document = report_summary(results, params=params, seeds=seeds, reference_settings=reference_settings,
                              measurement=measurement,
                              budgets=budgets, baseline_dir=baseline_dir, sweep=sweep, clock=clock.seconds)
    document = dataclasses.replace(
        document, animations=tuple(animation_rows(animations)), comparisons=tuple(row for row, _ in compared),
        frames=None if frames is None else FramesSummary(tuple(frames_rows(frames[0]) or ()), frames[1]["verdict"],
                                                         os.path.abspath(cast(str, frames_dir))))
    return write_report(out_dir, results, document, sweep, progress=progress, started=clock.started,
                        animation_media=[dict(a.media) for a in animations],
                        comparison_media=[comparison_images(row, views) for row, views in compared])


def _load_frames(folder: str) -> tuple:
    """A frame check's (table, manifest); ReportError naming the fix."""
    try:
        return load_frames(folder)
    except (OSError, ValueError, KeyError) as exc:
        raise ReportError(f"--frames {folder}: not a readable frame check ({exc}): run `volcaustics frames -o "
                          f"{folder}`") from None


def load_comparisons(pairs: Iterable[tuple[str, str]], names: Iterable[str]) -> list:
    """(row, views) of every comparison ``report --compare NAME=DIR`` names, each of a
    scene the report shows (by content: the scene hash), in the order given."""
    shown = {resolve_scene(name).scene_hash(): name for name in names}
    out: list
    out, seen = [], set()
    for name, folder in pairs:
        for path in comparison_folders(folder, f"--compare {name}="):
            c = load_comparison(path, f"--compare {name}=")
            if c.scene_hash not in shown:
                raise ReportError(f"--compare {name}={path}: compares {c.scene!r} (hash {c.scene_hash[:12]}), "
                                  f"which this report does not show (or shows changed): add it to --scenes, or "
                                  f"rerun compare on the scene as it is now")
            if (name, c.scene_hash) in seen:
                raise ReportError(f"--compare {name}={path}: a second comparison of {name} on {c.scene}: give "
                                  f"each renderer one folder per scene")
            seen.add((name, c.scene_hash))
            row = comparison_row(c, name)
            row["scene"], row["anchor"] = shown[c.scene_hash], f"compare-{len(out)}"
            out.append((row, c.views))
    return out

