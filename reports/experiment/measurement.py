"""The measurement settings (docs/architecture.md): how a point is
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
subset_batches     8        4–64    paired photon subsets per seed of A and the E images:
                                    the decomposition's jackknife batches (its noise)
exact_steps        512      32–1024 steps of the exact replay in the E_∞ images (< 0.1%
                                    of the power alive after 512 on every built-in:
                                    docs/decisions.md "Exact steps and the small kernel")
=================  =======  ======  ===================================================

Beside the table, ``scope`` (default "full"): what a point measures. The gate sets it
to "gate": only what its budgets read (``reports.gate.budgets``: the image metrics of
GATE_IMAGE_METRICS and the segments), so a gate point skips the exact replay, the
decomposition, the model term and the image metrics no budget names, and its key says
so. A full point (the report's) still serves the gate (``reports.runner``: a superset).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from volcaustics.approx.params import ParamError

# E_∞'s steps: scenes.formats.PATH_INTERACTIONS, the reference's path length (a test ties the
# two; not imported: that module loads numpy, and every command's parser reads this one)
EXACT_STEPS = 512
SUBSET_BATCHES = 8           # paired photon subsets per seed of A and the E images: the decomposition's noise
EXACT_SUBPHOTONS = 16        # exact replays of each emission texel in the E_∞ images (docs/decisions.md "Sub-photons")


def _int_setting(name: str, low: int, high: int, what: str, default: int):
    """A check of an integer measurement setting in [low, high]: value → value (None: the default)."""
    def check(value: int | None = None) -> int:
        if value is None:
            return default
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ParamError(f"{name} = {value!r}: expected an integer in [{low}, {high}] ({what}; default {default})")
        return value
    return check


# E_k is E_∞ cut at the approximation's steps (at most 32): E_∞ replays at least that many
exact_steps_setting = _int_setting("exact_steps", 32, 1024, "steps of the exact replay in the E_∞ images",
                                   EXACT_STEPS)
# the decomposition's jackknife needs 4 batches in all; one seed gives subset_batches of them
subset_batches_setting = _int_setting("subset_batches", 4, 64, "paired photon subsets per seed of A and the E "
                                      "images, the decomposition's jackknife batches", SUBSET_BATCHES)


# the E_∞ images' replays of each emission texel (docs/decisions.md "Sub-photons")
subphotons_setting = _int_setting("exact_subphotons", 1, 64, "exact replays of each emission texel in the "
                                  "decomposition's E_∞ images", EXACT_SUBPHOTONS)

# name → (check: value → int, ParamError naming the range; help)
MEASUREMENT_TABLE = {
    "exact_subphotons": (subphotons_setting, "exact replays of each emission texel in the error decomposition's E_∞ "
                                             "images, 1 to 64"),
    "subset_batches": (subset_batches_setting, "paired photon subsets per seed of A and the E images: the "
                                               "decomposition's jackknife batches, 4 to 64"),
    "exact_steps": (exact_steps_setting, "steps of the exact replay in the decomposition's E_∞ images (E_k is it cut "
                                         "at the approximation's steps), 32 to 1024"),
}
MEASUREMENT_KEYS = tuple(MEASUREMENT_TABLE)  # what a spec's or the budgets' [measurement] table may set
SCOPES = ("full", "gate")
# the image metrics a gate budget can name (reports.gate.budgets.COMPONENT_KEYS: relmse_max,
# frame_relmse_max, energy_ratio, hdr_flip_max; a test ties the two)
GATE_IMAGE_METRICS = ("relative_mse", "frame_relative_mse", "energy_ratio", "hdr_flip")


@dataclass(frozen=True)
class MeasurementSettings:
    """How a point is measured (module docstring); validated when made (ParamError)."""

    exact_subphotons: int = EXACT_SUBPHOTONS
    subset_batches: int = SUBSET_BATCHES
    exact_steps: int = EXACT_STEPS
    scope: str = "full"          # "full", or "gate": only what the gate's budgets read (module docstring)

    def __post_init__(self):
        for name, (check, _) in MEASUREMENT_TABLE.items():
            check(getattr(self, name))
        if self.scope not in SCOPES:
            raise ParamError(f"scope = {self.scope!r}: expected one of {', '.join(SCOPES)}")

    def to_dict(self) -> dict:
        """The settings as plain data: a result's key holds them (``reports.runner``)."""
        return dataclasses.asdict(self)


def measurement_settings(overrides: dict | None = None, *, where: str = "measurement",
                         base: MeasurementSettings | None = None) -> MeasurementSettings:
    """``base`` (default: the report's settings) with ``overrides`` (MEASUREMENT_KEYS,
    None values left out); ParamError for an unknown key or a value out of range, naming
    ``where``: a flag (``--exact-subphotons = 0: …``) or a table (``FILE: measurement``
    → ``FILE: measurement.exact_subphotons = 0: …``)."""
    changes = {k: v for k, v in (overrides or {}).items() if v is not None}
    for name, value in changes.items():
        if name not in MEASUREMENT_TABLE:
            raise ParamError(f"{where}.{name}: unknown; expected {', '.join(MEASUREMENT_KEYS)}")
        try:
            MEASUREMENT_TABLE[name][0](value)
        except ParamError as exc:
            named = where if where.startswith("--") else f"{where}.{name}"
            raise ParamError(f"{named} = {str(exc).split(' = ', 1)[1]}") from None
    return dataclasses.replace(base or MeasurementSettings(), **changes)
