"""The gate's checks on one measured scene, as a pure function of (result, limits,
baseline): the gate calls it strictly (anything it cannot check is an error, exit 2),
the report leniently (what could not be checked becomes a note on the page)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

from volcaustics.reports.studies.gate.budgets import GateError, budget_checks
from volcaustics.reports.studies.gate.regression import baseline_entry, regression_check

if TYPE_CHECKING:
    from volcaustics.reports.studies.gate.budgets import MeasuredResult


@dataclass
class Verdict:
    checks: list                               # budgets.Check, budgets first, then the regression test
    entry: dict | None = None                  # this result as a baseline entry (None: it cannot be one)
    notes: list = field(default_factory=list)  # lenient mode: what was not checked, and why


def scene_verdict(name: str, result: MeasuredResult, limits: dict, baseline: dict | None = None, *,
                  strict: bool = True) -> Verdict:
    """The budgets ``limits`` of scene ``name`` checked on ``result`` (``.experiment`` and
    ``.segments``, e.g. ``reports.measuring.runner.PointResult``) and, with ``baseline`` (the
    baseline file's document), the regression test against its entry ``name``: the budgets
    key as written (``mine/scene.toml`` for a scene file, not the scene's own name), the
    key the gate accepts a baseline under.

    strict: a budget the noise cannot resolve, a NaN metric, a missing or mismatching
    baseline entry raise GateError; lenient: they become ``notes``."""
    verdict = Verdict(checks=[])
    try:
        verdict.checks = budget_checks(name, limits, result.experiment.metric, result.segments)
    except GateError as exc:
        if strict:
            raise
        verdict.notes.append(f"budgets not checked: {exc}")
    try:
        verdict.entry = baseline_entry(result)
    except GateError as exc:
        if strict:
            raise
        if baseline is not None:
            verdict.notes.append(f"regression not tested: {exc}")
        return verdict
    if baseline is not None:
        _regression(verdict, name, baseline, strict)
    return verdict


def _regression(verdict: Verdict, name: str, baseline: dict, strict: bool) -> None:
    entry = cast(dict, verdict.entry)  # made before the regression test is asked for
    base = baseline["scenes"].get(name)  # keyed as the gate wrote it: the budgets key, never the scene's name
    if base is None:
        problem = ("the baseline has no entry for this scene: no regression test",
                   f"the baseline has no entry for {name!r}: update the baseline")
    elif base.get("reference_key") != entry["reference_key"]:
        problem = ("the baseline was measured against another reference: no regression test (update the baseline)",
                   f"{name}: the baseline was measured against reference {base.get('reference_key')}, this run "
                   f"against {entry['reference_key']}: update the baseline")
    else:
        verdict.checks.append(regression_check(name, entry, base))
        return
    if strict:
        raise GateError(problem[1])
    verdict.notes.append(problem[0])
