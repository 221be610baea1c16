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
from volcaustics.experiment.summaries import SCHEMAS
from volcaustics.infra.errors import InputError

if TYPE_CHECKING:
    import pandas as pd

    from volcaustics.experiment.summaries import ExperimentSummary


def from_stored(value: Any) -> float:
    """A stored number, NaN for None (the store writes NaN as null)."""
    return math.nan if value is None else float(value)


def to_stored(value: float) -> float | None:
    """A number as the store writes it: None for NaN."""
    return None if math.isnan(value) else value


# a stored image metric's fields (the summary's "images", experiment.image_rows writes them)
HEADLINE_COLUMNS = ("value", "debiased", "standard_error", "ci_low", "ci_high", "reference_floor", "approx_noise",
                    "reference_sigma", "note")
ESTIMATE_KEYS = ("value", "debiased", "standard_error")  # what every estimate stores (the model term's: only these)


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
    reference_floor: float = math.nan   # the reference's noise the debiased value had subtracted
    approx_noise: float = math.nan      # the frames' own noise it had subtracted
    reference_sigma: float = math.nan   # the reference total's relative σ (energy_ratio)
    note: str = ""                      # why the metric is not measured ("" when it is)
    per_seed: tuple[float, ...] | None = None   # each frame's own value (relative_mse)

    @classmethod
    def from_json(cls, data: Mapping) -> Estimate:
        per_seed = data.get("per_seed")
        numbers = {k: from_stored(data.get(k)) for k in HEADLINE_COLUMNS if k != "note"}
        return cls(**numbers, note=str(data.get("note") or ""),
                   per_seed=None if per_seed is None else tuple(from_stored(v) for v in per_seed))

    def to_json(self, keys: tuple[str, ...] = HEADLINE_COLUMNS) -> dict:
        """The stored form (``keys`` of it; NaN as None, ``per_seed`` where there is one)."""
        out: dict[str, Any] = {k: getattr(self, k) if k == "note" else to_stored(getattr(self, k)) for k in keys}
        if self.per_seed is not None:
            out["per_seed"] = [to_stored(v) for v in self.per_seed]
        return out


@dataclass(frozen=True)
class ImageMetric:
    """One metric of one image component (``caustic``, ``fog``, ``direct``, ``total``)
    against the reference: ``metric`` as the summary names it (``relative_mse``: the
    seeds' mean image; ``frame_relative_mse``: one frame; ``energy_ratio``, ``hdr_flip``, …)."""

    component: str
    metric: str
    estimate: Estimate


def find_estimate(images: tuple[ImageMetric, ...], metric: str, component: str) -> Estimate | None:
    """The estimate of ``metric`` on ``component`` among ``images``, None where absent."""
    return next((m.estimate for m in images if m.component == component and m.metric == metric), None)


@dataclass(frozen=True)
class DecompositionRow:
    """One cause of the caustic's error (docs/concepts/decomposition.md): its share of the
    reference's energy and its part of the relative MSE, each ± its standard error
    (``relmse_part_debiased``: the part with the frames' noise taken out; ``relmse_own``:
    the cause's own relative MSE, as if it were the only error). The ``noise`` row has no
    energy share (NaN): ``energy_share_se`` holds the σ of the frames' energy,
    ``relmse_part`` (and its debiased copy) the noise's relative MSE."""

    term: str
    energy_share: float
    energy_share_se: float
    relmse_part: float
    relmse_part_se: float
    relmse_part_debiased: float
    relmse_own: float = math.nan
    relmse_own_se: float = math.nan

    @classmethod
    def from_json(cls, row: Mapping) -> DecompositionRow:
        if row.get("term") == "noise":
            noise = from_stored(row.get("relmse"))
            return cls("noise", math.nan, from_stored(row.get("energy_sigma")), noise, math.nan, noise)
        return cls(str(row["term"]), *(from_stored(row.get(k)) for k in _ROW_NUMBERS))

    def to_json(self) -> dict:
        """The stored row."""
        if self.term == "noise":
            return {"term": "noise", "energy_sigma": to_stored(self.energy_share_se),
                    "relmse": to_stored(self.relmse_part)}
        stored = ("energy_share", "energy_share_se", "relmse_part", "relmse_part_se", "relmse_own", "relmse_own_se",
                  "relmse_part_debiased")
        return {"term": self.term, **{k: to_stored(getattr(self, k)) for k in stored}}


_ROW_NUMBERS = ("energy_share", "energy_share_se", "relmse_part", "relmse_part_se", "relmse_part_debiased",
                "relmse_own", "relmse_own_se")  # DecompositionRow's numbers, in its order


@dataclass(frozen=True)
class Closure:
    """Whether the decomposition closes: the residual's energy share and debiased relative
    MSE, each with its standard error and z-score, ``within_noise`` when both |z| are
    within the limit, and the warning's ``message`` when not."""

    energy_share: float
    energy_se: float
    energy_z: float
    debiased_relmse: float
    relmse_se: float
    relmse_z: float
    within_noise: bool
    message: str

    @classmethod
    def from_json(cls, data: Mapping) -> Closure:
        def n(name: str) -> float:
            return from_stored(data.get(name))

        return cls(n("energy_share"), n("energy_se"), n("energy_z"), n("debiased_relmse"), n("relmse_se"),
                   n("relmse_z"), bool(data.get("within_noise")), str(data.get("message") or ""))

    def to_json(self) -> dict:
        return {k: v if isinstance(v, (bool, str)) else to_stored(v) for k, v in vars(self).items()}


@dataclass(frozen=True)
class FrameCost:
    """A frame's cost: ``counted`` (map and emission reads plus splats, the counted
    total) with its parts ``map_reads``, ``emission_reads`` and ``splats``, the pixels
    the denoiser ran on (``denoised_pixels``), ``predicted`` (weight set → predicted frame
    seconds, the cost model) and ``measured_s`` (the frame's wall time, ``timing_method``
    says how). The means over the seeds' frames."""

    counted: float
    splats: float
    predicted: Mapping[str, float]
    measured_s: float
    timing_method: str
    map_reads: float = math.nan
    emission_reads: float = math.nan
    denoised_pixels: float = math.nan


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
        return cls({k: float(v) for k, v in data["predicted_ratio"].items()}, from_stored(t["ratio"]),
                   bool(data["at_paper_cost"]), from_stored(t.get("config_s")), from_stored(t.get("paper_s")),
                   str(t.get("method", "")))


@dataclass(frozen=True)
class ModelComponent:
    """The single-scattering model's term on one component (docs/concepts/model-term.md):
    the energy it leaves out (``energy_share``), its own relative MSE against the
    multiple-scattering reference (``relmse_own``), its part of the approximation's
    (``relmse_part``) and the approximation's whole error against that reference
    (``approx_part``); ``note`` where it could not be measured (the estimates None)."""

    component: str
    energy_share: Estimate | None
    relmse_own: Estimate | None
    relmse_part: Estimate | None
    note: str = ""
    approx_part: Estimate | None = None

    def to_json(self) -> dict:
        if self.note:
            return {"note": self.note}
        parts = {"energy_share": self.energy_share, "relmse_own": self.relmse_own, "relmse_part": self.relmse_part,
                 "approx_part": self.approx_part}
        return {name: e.to_json(ESTIMATE_KEYS) for name, e in parts.items() if e is not None}


@dataclass(frozen=True)
class ModelTerm:
    """The model term of a point whose reference has ``max_scatter`` > 1 orders:
    ``orders_needed`` per component (None: more than rendered), whether every component
    ``converged`` (by ``rule``), and its :class:`ModelComponent` per component."""

    max_scatter: int | None
    orders_needed: Mapping[str, int | None]
    converged: bool
    components: tuple[ModelComponent, ...]
    rule: str = ""

    @classmethod
    def from_json(cls, data: Mapping | None) -> ModelTerm | None:
        if data is None:
            return None
        parts = []
        for component, m in data["components"].items():
            if "note" in m:
                parts.append(ModelComponent(component, None, None, None, str(m["note"])))
            else:
                def e(name: str, m: Mapping = m) -> Estimate | None:
                    return Estimate.from_json(m[name]) if name in m else None

                parts.append(ModelComponent(component, e("energy_share"), e("relmse_own"), e("relmse_part"),
                                            approx_part=e("approx_part")))
        return cls(data.get("max_scatter"), dict(data.get("orders_needed") or {}), bool(data.get("converged")),
                   tuple(parts), str(data.get("rule", "")))

    def to_json(self) -> dict:
        """The stored form."""
        return {"max_scatter": self.max_scatter, "orders_needed": dict(self.orders_needed),
                "converged": self.converged, "components": {c.component: c.to_json() for c in self.components},
                "rule": self.rule}


@dataclass(frozen=True)
class MapReads:
    """The light-map reads of a frame: ``per_frame``, ``per_segment`` (the search's
    cost of one segment, averaged) and ``per_step`` (per segment at each step)."""

    per_frame: float
    per_segment: float
    per_step: tuple[float, ...] = ()

    @classmethod
    def from_json(cls, data: Mapping | None) -> MapReads | None:
        if not data:
            return None
        return cls(from_stored(data.get("per_frame")), from_stored(data.get("per_segment")),
                   tuple(data.get("per_step", ())))

    def to_json(self) -> dict:
        return {"per_frame": self.per_frame, "per_segment": self.per_segment, "per_step": list(self.per_step)}


@dataclass(frozen=True)
class ReferenceUsed:
    """The reference a point was measured against: its cache ``key``, the ``settings`` it
    was rendered with, its relative ``noise_floor`` per component and why it stopped
    (``stopped_by``). ``to_json`` gives the whole stored record (the reference cache's
    own fields: its request, batches, variant, …), which the report shows as it is."""

    key: str
    settings: Mapping[str, Any]
    noise_floor: Mapping[str, float | None]
    stopped_by: str
    record: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, data: Mapping) -> ReferenceUsed:
        return cls(str(data.get("key", "")), dict(data.get("settings") or {}), dict(data.get("noise_floor") or {}),
                   str(data.get("stopped_by", "")), dict(data))

    @property
    def photons(self) -> int | None:
        """Photons traced for the caustic (the cache record's count)."""
        return self.record.get("photons")

    @property
    def batches(self) -> int | None:
        """Caustic batches rendered."""
        return self.record.get("batches")

    @property
    def camera_batches(self) -> int | None:
        """Camera (fog and direct) batches rendered."""
        return self.record.get("camera_batches")

    def to_json(self) -> dict:
        return dict(self.record)


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
    description: str = ""
    optical_depth: float = math.nan   # the scene's medium along the light's axis
    seed_values: tuple[int, ...] = ()
    reference: ReferenceUsed | None = None
    compared_pixels: int = 0          # the pixels every metric compares (the mask)
    closure: Closure | None = None    # the decomposition's residual against its noise (None: no decomposition)
    paths: Mapping[str, Any] = field(default_factory=dict)  # where the frames' photon paths first diverge
    timings: Mapping[str, float] = field(default_factory=dict)  # pass → seconds of the timed frame; "frame_wall"
    timed_frames: int = 0
    gl_renderer: str | None = None
    summary_sha256: str = ""          # the stored summary's seal: another measurement of the point differs
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
        decomposition = summary.get("decomposition")
        return cls(
            scene=summary["scene"], scene_hash=summary["scene_hash"], key=key or str(summary.get("key", "")),
            params=ApproxParams(**summary["params"]), seeds=int(summary["seeds"]), images=images,
            decomposition=tuple(DecompositionRow.from_json(r) for r in rows),
            cost=FrameCost(from_stored(cost.get("total")), from_stored(cost.get("splats")),
                           {k: float(v) for k, v in summary.get("predicted_frame", {}).items() if v is not None},
                           from_stored(timings.get("frame_wall")), str(summary.get("timing_method", "")),
                           from_stored(cost.get("map_reads")), from_stored(cost.get("emission_reads")),
                           from_stored(cost.get("denoised_pixels"))),
            equal_cost=EqualCost.from_json(summary.get("equal_cost")), warnings=tuple(summary["warnings"]),
            code_version=summary["code_version"], tables=dict(tables or {}),
            model=ModelTerm.from_json(summary.get("model")),
            map_reads=MapReads.from_json(reads),
            seconds=from_stored((summary.get("experiment_seconds") or {}).get("total")),
            description=str(summary.get("description", "")), optical_depth=from_stored(summary.get("optical_depth")),
            seed_values=tuple(summary.get("seed_values", ())),
            reference=ReferenceUsed.from_json(summary["reference"]) if summary.get("reference") else None,
            compared_pixels=int(summary.get("compared_pixels") or 0),
            closure=Closure.from_json(decomposition["residual"]) if decomposition else None,
            paths=dict(summary.get("paths") or {}), timings={k: float(v) for k, v in timings.items()},
            timed_frames=int(summary.get("timed_frames") or 0),
            gl_renderer=(summary.get("gl") or {}).get("renderer"),
            summary_sha256=str(summary.get("summary_sha256", "")))

    def metric(self, metric: str = "relative_mse", component: str = "caustic") -> Estimate:
        """One image metric (:class:`ImageMetric`); KeyError naming those there are."""
        found = self.find_metric(metric, component)
        if found is not None:
            return found
        there = sorted({(m.component, m.metric) for m in self.images})
        raise KeyError(f"no {component} {metric} in this experiment; it has {there}")

    def find_metric(self, metric: str = "relative_mse", component: str = "caustic") -> Estimate | None:
        """One image metric, None where this experiment did not measure it (a gate point
        measures only the metrics its budgets read)."""
        return find_estimate(self.images, metric, component)

    def images_table(self) -> pd.DataFrame:
        """The image metrics, a row per (component, metric)."""
        import pandas as pd

        return pd.DataFrame([{"component": m.component, "metric": m.metric, **vars(m.estimate)}
                             for m in self.images])

    def decomposition_table(self) -> pd.DataFrame:
        """The decomposition of the caustic's error, a row per cause."""
        import pandas as pd

        return pd.DataFrame([vars(r) for r in self.decomposition])
