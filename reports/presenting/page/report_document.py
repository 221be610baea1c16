"""The accuracy report's own document, typed: what its ``summary.json`` holds.

``report_summary`` builds a :class:`ReportDocument`, the page is drawn from it, the CLI
prints from it and ``run_report`` returns it. Each part reads itself from its stored form
(``from_json``, once, where ``summary.json`` is read) and writes it back (``to_json``) key
for key, so that the file is what it was before these types. The page is drawn from the
document read back from its own strict JSON: every number on the page is in the file.

Table rows stay records, as tables are drawn: a scene's hit classes and power budget, a
sweep's rows, the animations', comparisons' and frame check's rows.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from volcaustics.experiment.result import (
    Closure,
    DecompositionRow,
    Estimate,
    MapReads,
    ModelTerm,
    ReferenceUsed,
    from_stored,
    to_stored,
)
from volcaustics.reports.studies.gate.budgets import Check

NOISE_FLOOR = "reference_noise_floor"  # a component's floor, stored beside its metrics
MISSING = Estimate(math.nan)  # a metric not measured: every number NaN (drawn as "–")


@dataclass(frozen=True)
class ComponentErrors:
    """One component's headline metrics (metric → estimate; None: not measured) and the
    reference's noise floor over the compared pixels (what the debiased error subtracted)."""

    metrics: Mapping[str, Estimate | None]
    reference_noise_floor: float

    def estimate(self, name: str) -> Estimate:
        """The metric's estimate; :data:`MISSING` (all NaN) when not measured."""
        return self.metrics.get(name) or MISSING

    @classmethod
    def from_json(cls, data: Mapping) -> ComponentErrors:
        return cls({k: Estimate.from_json(v) if v else None for k, v in data.items() if k != NOISE_FLOOR},
                   from_stored(data.get(NOISE_FLOOR)))

    def to_json(self) -> dict:
        out: dict[str, Any] = {k: {} if e is None else e.to_json() for k, e in self.metrics.items()}
        out[NOISE_FLOOR] = to_stored(self.reference_noise_floor)
        return out


def _checks_json(checks) -> list:
    return [dataclasses.asdict(c) for c in checks]


@dataclass(frozen=True)
class SceneGate:
    """A scene's gate: ``passed`` (None: nothing checked), the note, whether it has budgets, its checks."""

    passed: bool | None
    note: str | None
    budgeted: bool
    checks: tuple[Check, ...]

    @property
    def failed(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if not c.passed)

    @classmethod
    def from_json(cls, data: Mapping) -> SceneGate:
        return cls(data.get("passed"), data.get("note"), bool(data.get("budgeted")),
                   tuple(Check(**c) for c in data.get("checks", ())))

    def to_json(self) -> dict:
        return {"passed": self.passed, "note": self.note, "budgeted": self.budgeted,
                "checks": _checks_json(self.checks)}


@dataclass(frozen=True)
class GateSummary:
    """The report's gate over every scene: passed (None: not fully checked), checks and
    failures counted, scenes with budgets that could not be checked, scenes without any."""

    passed: bool | None
    checks: int
    failed: int
    unchecked_scenes: tuple[str, ...]
    scenes_without_budgets: tuple[str, ...]

    @classmethod
    def from_json(cls, data: Mapping) -> GateSummary:
        return cls(data.get("passed"), int(data["checks"]), int(data["failed"]), tuple(data["unchecked_scenes"]),
                   tuple(data["scenes_without_budgets"]))

    def to_json(self) -> dict:
        return {"passed": self.passed, "checks": self.checks, "failed": self.failed,
                "unchecked_scenes": list(self.unchecked_scenes),
                "scenes_without_budgets": list(self.scenes_without_budgets)}


@dataclass(frozen=True)
class PassShare:
    """One pass of the timed frame: its seconds and its share of the frame ("other": the rest)."""

    name: str
    seconds: float
    share: float


@dataclass(frozen=True)
class PassTiming:
    """One frame's time per pass (``report_summary.timing``) with the paper's shares beside."""

    method: str
    frame_s: float
    passes: tuple[PassShare, ...]
    paper_shares: Mapping[str, float]
    timed_frames: int
    gl_renderer: str | None
    map_reads: MapReads | None

    @classmethod
    def from_json(cls, data: Mapping) -> PassTiming:
        return cls(str(data["method"]), from_stored(data.get("frame_s")),
                   tuple(PassShare(p["pass"], from_stored(p.get("seconds")), from_stored(p.get("share")))
                         for p in data["passes"]),
                   dict(data["paper_shares"]), int(data.get("timed_frames") or 0), data.get("gl_renderer"),
                   MapReads.from_json(data.get("map_reads")))

    def to_json(self) -> dict:
        return {"method": self.method, "frame_s": self.frame_s,
                "passes": [{"pass": p.name, "seconds": p.seconds, "share": p.share} for p in self.passes],
                "paper_shares": dict(self.paper_shares), "timed_frames": self.timed_frames,
                "gl_renderer": self.gl_renderer,
                "map_reads": None if self.map_reads is None else self.map_reads.to_json()}


@dataclass(frozen=True)
class PageDecomposition:
    """The caustic's decomposition as the page shows it: the terms in ``TERMS`` order, their
    total, the noise row and the residual's closure."""

    terms: tuple[DecompositionRow, ...]
    total: DecompositionRow
    noise: DecompositionRow
    residual: Closure

    @classmethod
    def from_json(cls, data: Mapping) -> PageDecomposition:
        row = DecompositionRow.from_json
        return cls(tuple(row(t) for t in data["terms"]), row(data["total"]), row(data["noise"]),
                   Closure.from_json(data["residual"]))

    def to_json(self) -> dict:
        return {"terms": [t.to_json() for t in self.terms], "total": self.total.to_json(),
                "noise": self.noise.to_json(), "residual": self.residual.to_json()}


@dataclass(frozen=True)
class ScenePage:
    """Everything the page shows of one scene (``report_summary.scene_page``)."""

    scene: str
    description: str
    scene_hash: str
    point: str                         # the result store's key
    measured_in_this_run: bool
    params: Mapping[str, Any]          # the approximation's parameters (name → value)
    shown_params: Mapping[str, Any]    # those the page lists
    seed_values: tuple[int, ...]
    reference: ReferenceUsed | None
    compared_pixels: int
    components: Mapping[str, ComponentErrors]
    gate: SceneGate
    timing: PassTiming
    hit_classes: Mapping[str, list]    # rows by step and layer, and by step (records)
    power_budget: tuple[Mapping[str, Any], ...]  # rows by tracer and step (records)
    decomposition: PageDecomposition
    model: ModelTerm | None
    paths: Mapping[str, Any]
    exposure: Mapping[str, float]      # component → the exposure every image of it shares
    warnings: tuple[str, ...]

    @classmethod
    def from_json(cls, d: Mapping) -> ScenePage:
        return cls(
            str(d["scene"]), str(d["description"]), str(d["scene_hash"]), str(d["point"]),
            bool(d["measured_in_this_run"]), dict(d["params"]), dict(d["shown_params"]), tuple(d["seed_values"]),
            ReferenceUsed.from_json(d["reference"]) if d.get("reference") else None, int(d["compared_pixels"]),
            {c: ComponentErrors.from_json(v) for c, v in d["components"].items()}, SceneGate.from_json(d["gate"]),
            PassTiming.from_json(d["timing"]), dict(d["hit_classes"]), tuple(d["power_budget"]),
            PageDecomposition.from_json(d["decomposition"]),
            ModelTerm.from_json(d.get("model")), dict(d["paths"]),
            {c: from_stored(v) for c, v in d["exposure"].items()}, tuple(d["warnings"]))

    def to_json(self) -> dict:
        return {
            "scene": self.scene, "description": self.description, "scene_hash": self.scene_hash, "point": self.point,
            "measured_in_this_run": self.measured_in_this_run, "params": dict(self.params),
            "shown_params": dict(self.shown_params), "seed_values": list(self.seed_values),
            "reference": None if self.reference is None else self.reference.to_json(),
            "compared_pixels": self.compared_pixels,
            "components": {c: v.to_json() for c, v in self.components.items()},
            "gate": self.gate.to_json(), "timing": self.timing.to_json(), "hit_classes": dict(self.hit_classes),
            "power_budget": list(self.power_budget),
            "decomposition": self.decomposition.to_json(),
            "model": None if self.model is None else self.model.to_json(), "paths": dict(self.paths),
            "exposure": dict(self.exposure), "warnings": list(self.warnings),
        }


@dataclass(frozen=True)
class SweepSummary:
    """What the page shows of a sweep store (``report --sweep``): which parameters it varied,
    the settings that suffice, every point's row, its variants' and best search's tables
    (records) and the figures drawn from it (paths under the report's folder)."""

    folder: str
    varied: tuple[str, ...]
    spec: Any
    points: int
    suffice: tuple[Mapping[str, Any], ...]
    point_rows: tuple[Mapping[str, Any], ...]
    suffice_factor: float | None
    figures: tuple[str, ...]
    variants: Mapping[str, Any] | None
    best: Mapping[str, Any] | None
    notes: tuple[str, ...]

    @classmethod
    def from_json(cls, d: Mapping | None) -> SweepSummary | None:
        if d is None:
            return None
        return cls(str(d["folder"]), tuple(d["varied"]), d["spec"], int(d["points"]), tuple(d["suffice"]),
                   tuple(d["point_rows"]), d.get("suffice_factor"), tuple(d.get("figures", ())), d.get("variants"),
                   d.get("best"), tuple(d.get("notes", ())))

    def to_json(self) -> dict:
        return {"folder": self.folder, "varied": list(self.varied), "spec": self.spec, "points": self.points,
                "suffice": list(self.suffice), "point_rows": list(self.point_rows),
                "suffice_factor": self.suffice_factor, "figures": list(self.figures), "variants": self.variants,
                "best": self.best, "notes": list(self.notes)}


@dataclass(frozen=True)
class FramesSummary:
    """The frame check the page shows (``report --frames``): its rows (records), verdict and folder."""

    rows: tuple[Mapping[str, Any], ...]
    verdict: Mapping[str, Any]
    folder: str

    @classmethod
    def from_json(cls, d: Mapping | None) -> FramesSummary | None:
        return None if d is None else cls(tuple(d["rows"]), dict(d["verdict"]), str(d["folder"]))

    def to_json(self) -> dict:
        return {"rows": list(self.rows), "verdict": dict(self.verdict), "folder": self.folder}


@dataclass(frozen=True)
class ReportDocument:
    """The report's ``summary.json``: its settings, the gate, every scene's page, the sweep,
    the animations', comparisons' and frame check's rows, versions and the stages' seconds."""

    kind: str
    created: str
    params: Mapping[str, Any]
    seeds: int
    reference_settings: Mapping[str, Any]
    measurement: Mapping[str, Any]
    budgets: str                       # the budgets file
    baseline: str | None               # the gate's baseline folder
    gate: GateSummary
    scales: Mapping[str, Mapping[str, Any]]   # error maps' fixed scales, as stored (figures.scales.Scale.to_dict)
    exposure_rule: str
    scenes: tuple[ScenePage, ...]
    sweep: SweepSummary | None
    gl_renderers: tuple[str, ...]
    code_version: str
    versions: Mapping[str, Any]
    seconds: Mapping[str, float]       # per stage; "page" and "total" once written
    animations: tuple[Mapping[str, Any], ...] = ()
    comparisons: tuple[Mapping[str, Any], ...] = ()
    frames: FramesSummary | None = None
    extra: Mapping[str, Any] = field(default_factory=dict, compare=False)  # keys this code does not know, kept

    @classmethod
    def from_json(cls, d: Mapping) -> ReportDocument:
        known = {f.name for f in dataclasses.fields(cls)}
        return cls(
            str(d["kind"]), str(d["created"]), dict(d["params"]), int(d["seeds"]), dict(d["reference_settings"]),
            dict(d.get("measurement") or {}), str(d["budgets"]), d.get("baseline"), GateSummary.from_json(d["gate"]),
            dict(d["scales"]), str(d["exposure_rule"]), tuple(ScenePage.from_json(p) for p in d["scenes"]),
            SweepSummary.from_json(d.get("sweep")), tuple(d["gl_renderers"]), str(d["code_version"]),
            dict(d["versions"]), dict(d["seconds"]), tuple(d.get("animations") or ()),
            tuple(d.get("comparisons") or ()), FramesSummary.from_json(d.get("frames")),
            {k: v for k, v in d.items() if k not in known})

    def to_json(self) -> dict:
        return {
            "kind": self.kind, "created": self.created, "params": dict(self.params), "seeds": self.seeds,
            "reference_settings": dict(self.reference_settings), "measurement": dict(self.measurement),
            "budgets": self.budgets, "baseline": self.baseline, "gate": self.gate.to_json(),
            "scales": dict(self.scales), "exposure_rule": self.exposure_rule,
            "scenes": [p.to_json() for p in self.scenes],
            "sweep": None if self.sweep is None else self.sweep.to_json(),
            "gl_renderers": list(self.gl_renderers), "code_version": self.code_version,
            "versions": dict(self.versions), "seconds": dict(self.seconds), "animations": list(self.animations),
            "comparisons": list(self.comparisons), "frames": None if self.frames is None else self.frames.to_json(),
            **self.extra,
        }


DOCUMENT_FIELDS = frozenset({*(f.name for f in dataclasses.fields(ReportDocument)), "extra"})
STUDY_FIELDS = ("sweep", "animations", "comparisons", "frames")  # the built-in studies' fields, typed here
