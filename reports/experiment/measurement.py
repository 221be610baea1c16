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
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from volcaustics.approx.params import ParamError
from volcaustics.reports.experiment.exact_images import EXACT_SUBPHOTONS, subphotons_setting

# name → (check: value → int, ParamError naming the range; help)
MEASUREMENT_TABLE = {
    "exact_subphotons": (subphotons_setting, "exact replays of each emission texel in the error decomposition's E_∞ "
                                             f"images: 1 to 64 (default {EXACT_SUBPHOTONS}, the report's)"),
}
MEASUREMENT_KEYS = tuple(MEASUREMENT_TABLE)  # what a spec's or the budgets' [measurement] table may set


@dataclass(frozen=True)
class MeasurementSettings:
    """How a point is measured (module docstring); validated when made (ParamError)."""

    exact_subphotons: int = EXACT_SUBPHOTONS

    def __post_init__(self):
        for name, (check, _) in MEASUREMENT_TABLE.items():
            check(getattr(self, name))

    def to_dict(self) -> dict:
        """The settings as plain data: a result's key holds them (``reports.runner``)."""
        return dataclasses.asdict(self)


def measurement_settings(overrides: dict | None = None, *, where: str = "measurement",
                         base: MeasurementSettings | None = None, error=ParamError) -> MeasurementSettings:
    """``base`` (default: the report's settings) with ``overrides`` (MEASUREMENT_KEYS,
    None values left out); ``error`` naming ``where`` (a table, or a flag's name) for an
    unknown key or a value out of range."""
    changes = {k: v for k, v in (overrides or {}).items() if v is not None}
    unknown = [k for k in changes if k not in MEASUREMENT_TABLE]
    if unknown:
        raise error(f"{where}.{unknown[0]}: unknown; expected {', '.join(MEASUREMENT_KEYS)}")
    try:
        return dataclasses.replace(base or MeasurementSettings(), **changes)
    except ParamError as exc:
        raise error(f"{where}: {exc}") from None
