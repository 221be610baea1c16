"""`volcaustics gate`: fail when the approximation gets worse — budgets per scene
(``gate.budgets``) and a regression test against the last accepted results
(``gate.regression``), checked by ``gate.verdict`` on results the runner measured or
found in the result store it shares with the report.

Exit codes (docs/gate.md): 0 pass, 1 a budget exceeded or a regression, 2 bad input or
missing data — a missing reference or baseline entry, a NaN metric, a scene that does
not exist — never a pass.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable
from dataclasses import replace
from typing import TYPE_CHECKING

from volcaustics.experiment.point_checks import measured_settings
from volcaustics.experiment.versions import code_version
from volcaustics.infra.storage import remove_file
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.cost_match import with_auto_values
from volcaustics.reports.studies.animate.animation_read import load_animation
from volcaustics.reports.studies.compare.comparison_read import comparison_folders, load_comparison
from volcaustics.reports.studies.gate.budgets import GateError, check_measurable, compare_checks, flicker_checks
from volcaustics.reports.studies.gate.gate_outputs import VERDICT, GateResult, failure_images, write_outputs
from volcaustics.reports.studies.gate.regression import BASELINE, baseline_text, load_baseline
from volcaustics.reports.studies.gate.verdict import scene_verdict
from volcaustics.scenes import SceneError, resolve_scene

if TYPE_CHECKING:
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.reports.studies.animate.animation_read import MeasuredAnimation

MISSING_REFERENCE = "run `make report` (or the gate with --render-references) first"


def run_gate(budgets: dict, *, overrides: dict, baseline_dir: str | None, update_baseline: bool, out_dir: str,
             scenes: Iterable[str] | None = None, seeds: int | None = None, seed: int = 0,
             render_references: bool = False, junit: str | None = None, animation_dirs: Iterable[str] = (),
             comparisons: Iterable[tuple[str, str]] = (), measurement: MeasurementSettings | None = None,
             progress: bool = True) -> GateResult:
    """Measure every budgeted scene (or ``scenes``) not in the result store, check
    budgets and the baseline, write the failure images under ``out_dir`` and then, as
    one set, the accepted baseline, the JUnit file ``junit`` and ``out_dir``/gate.json.
    ``animation_dirs``: ``volcaustics animate`` outputs held to their flicker budgets;
    ``comparisons``: (RENDERER, DIR) pairs, ``volcaustics compare`` outputs (DIR: one or a
    folder of them) held to the budgets' ``[compare.RENDERER.SCENE]`` limits.
    ``measurement``: the measurement settings (None: the budgets' ``[measurement]``)."""
    t0 = time.perf_counter()
    names = _names(budgets, scenes)
    animations = [_animation(budgets, folder) for folder in animation_dirs or ()]  # bad input: before any work
    compared = [c for name, folder in comparisons or () for c in _comparisons(budgets, name, folder)]
    n_seeds = budgets["seeds"] if seeds is None else seeds
    params, n_seeds = measured_settings(budgets["preset"], overrides, seeds=n_seeds, seed=seed, min_seeds=2,
                                        why="the regression test needs 2")
    check_measurable(budgets, names, params)
    baseline = load_baseline(baseline_dir) if baseline_dir and not update_baseline else None
    absent = [n for n in names if baseline is not None and n not in baseline["scenes"]]
    if absent:
        raise GateError(f"{baseline_dir}/baseline.json: no entry for {absent[0]!r}: update the baseline")
    for stale in (os.path.join(out_dir, VERDICT), junit):  # an earlier verdict must not stand for this run
        if stale:
            remove_file(stale)
    # a preset whose photon_res is matched (best): per scene, unless --set gives photon_res
    points = [runner.Point(arg, with_auto_values(arg, params, budgets["preset"], "photon_res" in overrides,
                                                       layers_given="layers" in overrides),
                           n_seeds) for arg in (budgets["scene_args"][name] for name in names)]
    run = runner.measure(points, runner.results_store(),
                         reference_settings=budgets["reference_settings"],
                         # the gate's points measure what its budgets read: no exact replay, no decomposition
                         measurement=replace(measurement or budgets["measurement"], scope="gate"),
                         policy="missing" if render_references else "cached", images=("views",), parallel=True,
                         progress=progress,
                         hint=MISSING_REFERENCE)
    checks, entries = [], {}
    for name, result in zip(names, run.results):
        verdict = scene_verdict(name, result, budgets["scenes"][name], baseline, strict=True)
        entries[name] = verdict.entry
        for check in verdict.checks:
            if not check.passed:
                check.images = failure_images(out_dir, name, check, result.views)
        checks += verdict.checks
    for animation in animations:
        checks += flicker_checks(animation, budgets["animations"][animation.scene], budgets["path"])
    for name, comparison in compared:
        checks += compare_checks(comparison, name, budgets["compare"][name][comparison.scene],
                                 budgets["path"])
    failed = [c for c in checks if not c.passed]
    # only results that pass their budgets are accepted as the baseline
    updated = os.path.join(baseline_dir, BASELINE) if update_baseline and baseline_dir and not failed else None
    result = GateResult(checks=checks, exit_code=1 if failed else 0, seconds=time.perf_counter() - t0,
                        baseline=baseline_dir, updated_baseline=updated, measured=run.computed,
                        from_store=run.done_before)
    write_outputs(out_dir, result, params, n_seeds, budgets, baseline=baseline_text(entries) if updated else None,
                  junit=junit)
    return result


def _animation(budgets: dict, folder: str) -> MeasuredAnimation:
    """An animate output with flicker budgets, measured with this code."""
    animation = load_animation(folder)
    scene = animation.scene
    if scene not in budgets["animations"]:
        raise GateError(f"--animation {folder}: no [animation.{scene}] flicker budgets in {budgets['path']}")
    if animation.code_version != code_version():
        raise GateError(f"--animation {folder}: measured with other code (version "
                        f"{animation.code_version}, now {code_version()}): rerun "
                        f"`volcaustics animate {scene} -o {folder}`")
    return animation


def _comparisons(budgets: dict, name: str, folder: str) -> list:
    """(RENDERER, comparison) of every compare output in ``folder``, each with budgets
    and measured with this code."""
    option = f"--compare {name}="
    out = []
    for path in comparison_folders(folder, option):
        comparison = load_comparison(path, option, views=False)
        if comparison.scene not in budgets["compare"].get(name, {}):
            raise GateError(f"{option}{path}: no [compare.{name}.{comparison.scene}] budgets in {budgets['path']}")
        if comparison.code_version != code_version():
            raise GateError(f"{option}{path}: measured with other code (version {comparison.code_version}, now "
                            f"{code_version()}): rerun `volcaustics compare {comparison.scene} IMAGE.exr … -o {path}`")
        out.append((name, comparison))
    return out


def _names(budgets: dict, scenes) -> list:
    """The gated scenes: ``scenes`` or all in the budgets, each budgeted and existing."""
    names = list(scenes) if scenes else list(budgets["scenes"])
    missing = [n for n in names if n not in budgets["scenes"]]
    if missing:
        raise GateError(f"--scenes: {missing[0]!r} has no budgets in {budgets['path']}")
    for name in names:
        try:
            resolve_scene(budgets["scene_args"][name])
        except SceneError as exc:
            raise GateError(f"budgets: scene {name!r}: {exc}") from None
    return names
