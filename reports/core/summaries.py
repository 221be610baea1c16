"""The results that cross subpackages, typed: a field renamed fails in one place.

``SceneResult`` (one scene's experiment and the gate's verdicts on it, as the report
gathers them) and ``SweepTables`` (a sweep store's consolidated tables) are what
``reports.report`` hands ``reports.page``; the summaries written to disk carry a
``schema`` version (:data:`SCHEMAS`) that their readers check.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from volcaustics.infra.errors import InputError


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


# The version of each summary.json a command writes and another reads back: bumped when a
# field is renamed or its meaning changes, so that a reader refuses a folder it would misread.
# A summary without the field predates it and is version 1 (its fields are those of 1).
SCHEMAS = {"animation": 1, "comparison": 1}


def check_schema(summary: dict, kind: str, where: str, fix: str) -> None:
    """InputError naming ``where`` and ``fix`` unless ``summary`` is of this code's
    schema for ``kind``."""
    found = summary.get("schema", 1)
    if type(found) is not int or found != SCHEMAS[kind]:  # true is not schema 1
        raise InputError(f"{where}: summary.json is of {kind} schema {found!r}, this volcaustics reads "
                         f"{SCHEMAS[kind]}: {fix}")
