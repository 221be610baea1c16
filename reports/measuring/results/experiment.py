"""One experiment as typed values: what ``vc.measure`` returns (``import volcaustics as vc``).

A stored summary (``summaries.ExperimentSummary``, plain JSON data) is read into these
frozen dataclasses once, at the store's boundary (:meth:`Experiment.from_summary`);
callers read attributes, not string keys. Every number keeps the summary's unit
(relative MSE as a fraction, times in seconds, costs in map and emission reads).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from volcaustics.approx.params import ApproxParams
from volcaustics.infra.errors import InputError
from volcaustics.reports.measuring.results.summaries import SCHEMAS

if TYPE_CHECKING:
    import pandas as pd

    from volcaustics.reports.measuring.results.summaries import ExperimentSummary


def _number(value: Any) -> float:
    """A stored number, NaN for None (the store writes NaN as null)."""
    return math.nan if value is None else float(value)


@dataclass(frozen=True)
class Estimate:
    """A measured value with its uncertainty: ``value`` as measured, ``debiased`` with
    the estimator's own noise taken out (NaN where the metric has none), ``standard_error``
    and the interval ``ci_low`` … ``ci_high`` (NaN where not computed)."""

    value: float
    debiased: float = math.nan
    standard_error: float = math.nan
    ci_low: float = math.nan
    ci_high: float = math.nan

    @classmethod
    def from_json(cls, data: Mapping) -> Estimate:
        return cls(value=_number(data.get("value")), debiased=_number(data.get("debiased")),
                   standard_error=_number(data.get("standard_error")), ci_low=_number(data.get("ci_low")),
                   ci_high=_number(data.get("ci_high")))


@dataclass(frozen=True)
class ImageMetric:
    """One metric of one image component (``caustic``, ``fog``, ``direct``, ``total``)
    against the reference: ``metric`` as the summary names it (``relative_mse``: the
    seeds' mean image; ``frame_relative_mse``: one frame; ``energy_ratio``, ``hdr_flip``, …)."""

    component: str
    metric: str
    estimate: Estimate


@dataclass(frozen=True)
class DecompositionRow:
    """One cause of the caustic's error (docs/concepts/decomposition.md): its share of the
    reference's energy and its part of the relative MSE, each ± its standard error
    (``relmse_part_debiased``: the part with the frames' noise taken out). The ``noise``
    row has no energy share (NaN): ``energy_share_se`` holds the σ of the frames' energy,
    ``relmse_part`` (and its debiased copy) the noise's relative MSE."""

    term: str
    energy_share: float
    energy_share_se: float
    relmse_part: float
    relmse_part_se: float
    relmse_part_debiased: float

    @classmethod
    def from_json(cls, row: Mapping) -> DecompositionRow:
        if row.get("term") == "noise":
            return cls("noise", math.nan, _number(row.get("energy_sigma")), _number(row.get("relmse")), math.nan,
                       _number(row.get("relmse")))
        return cls(str(row["term"]), _number(row.get("energy_share")), _number(row.get("energy_share_se")),
                   _number(row.get("relmse_part")), _number(row.get("relmse_part_se")),
                   _number(row.get("relmse_part_debiased")))


@dataclass(frozen=True)
class FrameCost:
    """A frame's cost: ``counted`` (map and emission reads plus splats, the counted
    total), ``splats``, ``predicted`` (weight set → predicted frame seconds, the cost
    model) and ``measured_s`` (the frame's wall time, ``timing_method`` says how)."""

    counted: float
    splats: float
    predicted: Mapping[str, float]
    measured_s: float
    timing_method: str


@dataclass(frozen=True)
class EqualCost:
    """A preset matched to the paper configuration's cost, checked: ``predicted_ratio``
    (weight set → predicted frame time / the paper's), ``measured_ratio`` (measured frame
    time / the paper's, alternating frames) and whether both hold (``at_paper_cost``)."""

    predicted_ratio: Mapping[str, float]
    measured_ratio: float
    at_paper_cost: bool
    measured_s: float = math.nan      # the preset's frame, median of the alternating frames
    paper_s: float = math.nan         # the paper configuration's
    method: str = ""                  # how the two were timed

    @classmethod
    def from_json(cls, data: Mapping | None) -> EqualCost | None:
        if data is None:
            return None
        t = data["measured_time"]
        return cls({k: float(v) for k, v in data["predicted_ratio"].items()}, _number(t["ratio"]),
                   bool(data["at_paper_cost"]), _number(t.get("config_s")), _number(t.get("paper_s")),
                   str(t.get("method", "")))


@dataclass(frozen=True)
class ModelComponent:
    """The single-scattering model's term on one component (docs/concepts/model-term.md):
    the energy it leaves out (``energy_share``), its own relative MSE against the
    multiple-scattering reference (``relmse_own``) and its part of the approximation's
    (``relmse_part``); ``note`` where it could not be measured (the estimates None)."""

    component: str
    energy_share: Estimate | None
    relmse_own: Estimate | None
    relmse_part: Estimate | None
    note: str = ""


@dataclass(frozen=True)
class ModelTerm:
    """The model term of a point whose reference has ``max_scatter`` > 1 orders:
    ``orders_needed`` per component (None: more than rendered), whether every component
    ``converged``, and its :class:`ModelComponent` per component."""

    max_scatter: int | None
    orders_needed: Mapping[str, int | None]
    converged: bool
    components: tuple[ModelComponent, ...]

    @classmethod
    def from_json(cls, data: Mapping | None) -> ModelTerm | None:
        if data is None:
            return None
        parts = []
        for component, m in data["components"].items():
            if "note" in m:
                parts.append(ModelComponent(component, None, None, None, str(m["note"])))
            else:
                parts.append(ModelComponent(component, Estimate.from_json(m["energy_share"]),
                                            Estimate.from_json(m["relmse_own"]), Estimate.from_json(m["relmse_part"])))
        return cls(data.get("max_scatter"), dict(data.get("orders_needed") or {}), bool(data.get("converged")),
                   tuple(parts))


@dataclass(frozen=True)
class MapReads:
    """The light-map reads of a frame: ``per_frame``, and ``per_segment`` (the search's
    cost of one segment, averaged)."""

    per_frame: float
    per_segment: float


@dataclass(frozen=True)
class Experiment:
    """One experiment: the approximation's frames of ``params`` on ``scene`` (``seeds``
    frames) against the reference, every metric, the decomposition of the caustic's
    error and the frame's cost. ``key``: the result store's key of the point.
    ``tables``: "segments", "photons", "images" → pandas DataFrame (the tidy tables
    ``measure -o DIR`` writes)."""

    scene: str
    scene_hash: str
    key: str
    params: ApproxParams
    seeds: int
    images: tuple[ImageMetric, ...]
    decomposition: tuple[DecompositionRow, ...]
    cost: FrameCost
    equal_cost: EqualCost | None
    warnings: tuple[str, ...]
    code_version: str
    model: ModelTerm | None = None    # the single-scattering model's term (a reference with max_scatter > 1)
    map_reads: MapReads | None = None
    seconds: float = math.nan         # what measuring the point took (its experiment, all seeds)
    tables: Mapping[str, pd.DataFrame] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_summary(cls, summary: ExperimentSummary, *, key: str = "",
                     tables: Mapping[str, pd.DataFrame] | None = None) -> Experiment:
        """The experiment a stored summary describes; InputError for a summary of another
        schema (it names the one read and the one expected), or not an experiment's."""
        if not isinstance(summary, Mapping):
            raise InputError(f"summary = {summary!r}: expected an experiment's summary.json, read as a mapping")
        schema = summary.get("schema", 1)
        if schema != SCHEMAS["experiment"]:
            raise InputError(f"summary.json: schema = {schema!r}: this volcaustics reads experiment schema "
                             f"{SCHEMAS['experiment']}; measure the point again")
        missing = [k for k in ("images", "scene", "scene_hash", "params", "seeds", "cost", "approx_timings_s",
                               "warnings", "code_version") if k not in summary]
        if missing:
            raise InputError(f"summary.json: no {', '.join(missing)}: not an experiment's summary (measure writes one)")
        images = tuple(ImageMetric(component, metric, Estimate.from_json(value))
                       for component, metrics in summary["images"].items()
                       for metric, value in metrics.items() if isinstance(value, Mapping))
        rows = (summary.get("decomposition") or {}).get("rows", [])
        cost, timings, reads = summary["cost"], summary["approx_timings_s"], summary.get("map_reads")
        return cls(
            scene=summary["scene"], scene_hash=summary["scene_hash"], key=key or str(summary.get("key", "")),
            params=ApproxParams(**summary["params"]), seeds=int(summary["seeds"]), images=images,
            decomposition=tuple(DecompositionRow.from_json(r) for r in rows),
            cost=FrameCost(_number(cost.get("total")), _number(cost.get("splats")),
                           {k: float(v) for k, v in summary.get("predicted_frame", {}).items() if v is not None},
                           _number(timings.get("frame_wall")), str(summary.get("timing_method", ""))),
            equal_cost=EqualCost.from_json(summary.get("equal_cost")), warnings=tuple(summary["warnings"]),
            code_version=summary["code_version"], tables=dict(tables or {}),
            model=ModelTerm.from_json(summary.get("model")),
            map_reads=MapReads(_number(reads.get("per_frame")), _number(reads.get("per_segment"))) if reads else None,
            seconds=_number((summary.get("experiment_seconds") or {}).get("total")))

    def metric(self, metric: str = "relative_mse", component: str = "caustic") -> Estimate:
        """One image metric (:class:`ImageMetric`); KeyError naming those there are."""
        for m in self.images:
            if m.component == component and m.metric == metric:
                return m.estimate
        there = sorted({(m.component, m.metric) for m in self.images})
        raise KeyError(f"no {component} {metric} in this experiment; it has {there}")

    def images_table(self) -> pd.DataFrame:
        """The image metrics, a row per (component, metric)."""
        import pandas as pd

        return pd.DataFrame([{"component": m.component, "metric": m.metric, **vars(m.estimate)}
                             for m in self.images])

    def decomposition_table(self) -> pd.DataFrame:
        """The decomposition of the caustic's error, a row per cause."""
        import pandas as pd

        return pd.DataFrame([vars(r) for r in self.decomposition])
