"""The measurement settings (DESIGN.md "Measurement settings"): how a point is
measured, beside the parameter table of what is measured. Each is a command-line flag
(``reports.cli.common.add_measurement_flags``), a key of a sweep spec's or the
budgets' ``[measurement]`` table, and part of a result's key; never an environment
variable.

=================  =======  ======  ===================================================
name               default  range   what it sets
=================  =======  ======  ===================================================
exact_subphotons   16       1–64    exact replays of each emission texel in the error
                                    decomposition's E_∞ images (docs/decisions.md
                                    "Sub-photons"); the test suite measures most
                                    points with 1 for its time
=================  =======  ======  ===================================================

Beside the table, ``decomposition`` (default true): whether a point replays the exact
photons and decomposes the caustic's error. The gate sets it false, since no budget
reads a decomposition term (``reports.gate.budgets``): a gate point skips the exact
replay, and its key says so. A full point (the report's) still serves the gate
(``reports.runner``: a superset).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from volcaustics.approx.params import ParamError
from volcaustics.reports.experiment.exact_images import EXACT_SUBPHOTONS, subphotons_setting

# name → (check: value → int, ParamError naming the range; help)
MEASUREMENT_TABLE = {
    "exact_subphotons": (subphotons_setting, "exact replays of each emission texel in the error decomposition's E_∞ "
                                             "images, 1 to 64"),
}
MEASUREMENT_KEYS = tuple(MEASUREMENT_TABLE)  # what a spec's or the budgets' [measurement] table may set


@dataclass(frozen=True)
class MeasurementSettings:
    """How a point is measured (module docstring); validated when made (ParamError)."""

    exact_subphotons: int = EXACT_SUBPHOTONS
    decomposition: bool = True   # the exact replay and the error decomposition (module docstring)

    def __post_init__(self):
        for name, (check, _) in MEASUREMENT_TABLE.items():
            check(getattr(self, name))

    def to_dict(self) -> dict:
        """The settings as plain data: a result's key holds them (``reports.runner``)."""
        return dataclasses.asdict(self)


def measurement_settings(overrides: dict | None = None, *, where: str = "measurement",
                         base: MeasurementSettings | None = None, error=ParamError) -> MeasurementSettings:
    """``base`` (default: the report's settings) with ``overrides`` (MEASUREMENT_KEYS,
    None values left out); ``error`` for an unknown key or a value out of range, naming
    ``where``: a flag (``--exact-subphotons = 0: …``) or a table (``FILE: measurement``
    → ``FILE: measurement.exact_subphotons = 0: …``)."""
    changes = {k: v for k, v in (overrides or {}).items() if v is not None}
    for name, value in changes.items():
        if name not in MEASUREMENT_TABLE:
            raise error(f"{where}.{name}: unknown; expected {', '.join(MEASUREMENT_KEYS)}")
        try:
            MEASUREMENT_TABLE[name][0](value)
        except ParamError as exc:
            named = where if where.startswith("--") else f"{where}.{name}"
            raise error(f"{named} = {str(exc).split(' = ', 1)[1]}") from None
    return dataclasses.replace(base or MeasurementSettings(), **changes)
