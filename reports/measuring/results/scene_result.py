"""One scene of the report as the store holds it, read once into its typed experiment,
with the gate's verdicts on it."""

from __future__ import annotations

from dataclasses import dataclass, field

from volcaustics.experiment.result import Experiment


@dataclass
class SceneResult:
    """One scene's experiment as the store holds it, and the gate's verdicts on it."""

    name: str
    key: str
    experiment: Experiment   # the point's summary, typed (``Experiment.from_summary``)
    tables: dict             # "segments", "photons", "images" → pandas DataFrame
    views: dict              # experiment.point_summary.VIEWS name → H×W×3 float32
    checks: list = field(default_factory=list)   # reports.studies.gate.budgets.Check
    gate_note: str = ""      # why the gate could not check this scene (no budgets, a GateError)
    budgeted: bool = False   # the budgets have this scene
    measured: bool = False   # measured in this run (False: from the store)
