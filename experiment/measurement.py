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

Beside the table, ``scope`` (default "full"): what a point measures (SCOPE_PARTS). The gate
sets it to "gate": only what its budgets read (``reports.studies.gate.budgets``: the image
metrics of GATE_IMAGE_METRICS and the segments), so a gate point skips the exact replay, the
decomposition, the model term and the image metrics no budget names, and its key says
so. "decomposition" is what the caustic's closure reads: the exact images, the
decomposition and the image metrics it sums to, without the timed frames, the segments,
the photon paths and the model term (the closure tests' points). A full point (the
report's) serves either (``reports.measuring.runner``: a superset).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from volcaustics.approx.params import Param, ParamError

# E_∞'s steps: scenes.formats.PATH_INTERACTIONS, the reference's path length (a test ties the
# two; not imported: that module loads numpy, and every command's parser reads this one)
EXACT_STEPS = 512
SUBSET_BATCHES = 8           # paired photon subsets per seed of A and the E images: the decomposition's noise
EXACT_SUBPHOTONS = 16        # exact replays of each emission texel in the E_∞ images (docs/decisions.md "Sub-photons")


# what a point of each scope measures beside its record frames and GATE_IMAGE_METRICS: "timings" the
# untimed warm-up and the timed frames, "segments" the intersection table, "photons" the photon paths'
# table, "exact" the exact images and the caustic's decomposition, "metrics" every other image metric,
# "model" the model term
SCOPE_PARTS = {"full": frozenset({"timings", "segments", "photons", "exact", "metrics", "model"}),
               "gate": frozenset({"timings", "segments", "photons"}),
               "decomposition": frozenset({"exact"})}

# name, type, default, help, range: the settings a flag and a [measurement] table may set
# (MEASUREMENT_KEYS), then scope (set by the command: the gate's points are "gate")
MEASUREMENT_PARAMS: tuple = (
    Param("exact_subphotons", int, EXACT_SUBPHOTONS, "exact replays of each emission texel in the error "
          "decomposition's E_∞ images", low=1, high=64),
    # the decomposition's jackknife needs 4 batches in all; one seed gives subset_batches of them
    Param("subset_batches", int, SUBSET_BATCHES, "paired photon subsets per seed of A and the E images: the "
          "decomposition's jackknife batches", low=4, high=64),
    # E_k is E_∞ cut at the approximation's steps (at most 32): E_∞ replays at least that many
    Param("exact_steps", int, EXACT_STEPS, "steps of the exact replay in the decomposition's E_∞ images (E_k is "
          "it cut at the approximation's steps)", low=32, high=1024),
    Param("scope", str, "full", "what a point measures: full, gate (only what the gate's budgets read) or "
          "decomposition (only what the caustic's decomposition reads)", choices=tuple(SCOPE_PARTS)),
)
MEASUREMENT_KEYS = tuple(p.name for p in MEASUREMENT_PARAMS if p.name != "scope")  # a flag and a table key each
_BY_NAME = {p.name: p for p in MEASUREMENT_PARAMS}
# the image metrics a gate budget can name (reports.studies.gate.budgets.COMPONENT_KEYS: relmse_max,
# frame_relmse_max, energy_ratio, hdr_flip_max; a test ties the two)
GATE_IMAGE_METRICS = ("relative_mse", "frame_relative_mse", "energy_ratio", "hdr_flip")


def _setting(name: str):
    """The field of measurement setting ``name``: its default, and its :class:`Param` as
    the field's metadata ``"param"`` (as ``approx.params.declared``)."""
    return dataclasses.field(default=_BY_NAME[name].default, metadata={"param": _BY_NAME[name]})


def check_setting(name: str, value: object) -> None:
    """ParamError unless ``value`` is allowed for setting ``name``; the message names the
    setting, the value, the range, what it sets and its default."""
    param = _BY_NAME[name]
    try:
        param.check(value)
    except ParamError as exc:
        raise ParamError(f"{exc} ({param.help}; default {param.default})") from None


@dataclass(frozen=True)
class MeasurementSettings:
    """How a point is measured (module docstring): one field per :data:`MEASUREMENT_PARAMS`
    entry, which the field carries as its metadata ``"param"``; validated once, when made
    (ParamError)."""

    exact_subphotons: int = _setting("exact_subphotons")
    subset_batches: int = _setting("subset_batches")
    exact_steps: int = _setting("exact_steps")
    scope: str = _setting("scope")

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            check_setting(f.name, getattr(self, f.name))

    def to_dict(self) -> dict:
        """The settings as plain data: a result's key holds them (``reports.measuring.runner``)."""
        return dataclasses.asdict(self)


def measurement_settings(overrides: dict | None = None, *, where: str = "measurement",
                         base: MeasurementSettings | None = None) -> MeasurementSettings:
    """``base`` (default: the report's settings) with ``overrides`` (MEASUREMENT_KEYS,
    None values left out); ParamError for an unknown key or a value out of range, naming
    ``where``: a flag (``--exact-subphotons = 0: …``) or a table (``FILE: measurement``
    → ``FILE: measurement.exact_subphotons = 0: …``)."""
    changes = {k: v for k, v in (overrides or {}).items() if v is not None}
    for name in changes:
        if name not in MEASUREMENT_KEYS:
            raise ParamError(f"{where}.{name}: unknown; expected {', '.join(MEASUREMENT_KEYS)}")
    try:  # checked once, by the settings themselves; the message then names where the value came from
        return dataclasses.replace(base or MeasurementSettings(), **changes)
    except ParamError as exc:
        name, _, rest = str(exc).partition(" = ")
        raise ParamError(f"{where if where.startswith('--') else f'{where}.{name}'} = {rest}") from None
