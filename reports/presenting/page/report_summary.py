"""The accuracy report (``volcaustics report``, ``make report``): one self-contained
HTML page and ``summary.json``, drawn from results only (``reports.presenting.report`` renders
and measures; nothing here does).

:func:`report_summary` picks, groups and converts what the page shows (shares to
percent, pass times to shares of the frame) — every number on the page comes from it,
and it is written as ``summary.json`` — and :func:`write_report` draws the page from
that very data (``page.html``, ``page.write``) with the images of each scene's views.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, cast

import numpy as np

from volcaustics.approx.cost import TIMED_PASSES
from volcaustics.approx.params import PARAMS
from volcaustics.experiment.photons import FATES
from volcaustics.experiment.result import find_estimate
from volcaustics.experiment.versions import code_version, library_versions
from volcaustics.metrics.decomposition import TERMS
from volcaustics.metrics.intersection import OUTCOME_CLASSES
from volcaustics.reports.presenting.page.data_uris import SCALES, exposures
from volcaustics.reports.presenting.page.report_document import (
    ComponentErrors,
    GateSummary,
    PageDecomposition,
    PassShare,
    PassTiming,
    ReportDocument,
    SceneGate,
    ScenePage,
)
from volcaustics.scenes.formats import COLOUR_LAYERS

if TYPE_CHECKING:
    import pandas as pd

    from volcaustics.approx.params import ApproxParams
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.experiment.result import Closure, Experiment
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.reports.measuring.results.scene_result import SceneResult

# Wang, Wang & Chen: intersection estimation takes about 70% of a frame and splatting about 23% on their GPU
OUTPUT_FILES = ("index.html", "summary.json")  # in --out; the manifest, summary.json, last

PAPER_SHARES = {"trace": 0.70, "splat": 0.23, "other": 0.07}
PASSES = TIMED_PASSES
HEADLINE = ("relative_mse", "frame_relative_mse", "energy_ratio", "hdr_flip", "per_pixel_relative_mse")
SHOWN_PARAMS = tuple(p.name for p in PARAMS if p.name != "seed")  # the page's parameter list


def _finite(value):
    return value if isinstance(value, (int, float)) and np.isfinite(value) else None


def _percent_of(count, total):
    """100 · count / total; None without a total."""
    return 100.0 * float(count) / float(total) if total else None


def hit_classes(segments: pd.DataFrame) -> dict:
    """Segment classes as % of each step's segments: per step and light-map layer of the
    approximation's hit (``"none"`` when it found none), and per step with the |Δt|
    percentiles of true hits (mm). Self re-hits are counted by their class beyond the
    re-hit surface and given apart as ``self_rehit`` (docs/concepts/measuring.md)."""
    def classes(frame, total):
        out = {}
        for name in OUTCOME_CLASSES:
            count = frame[f"count_{name}"].sum()
            if f"count_beyond_self_rehit_{name}" in frame:
                count += frame[f"count_beyond_self_rehit_{name}"].sum()
            out[name] = _percent_of(count, total)
        out["self_rehit"] = _percent_of(frame["count_self_rehit"].sum(), total)
        return out

    by_map = segments[segments["grouping"] == "step,map,inside"]
    by_step = segments[segments["grouping"] == "step"]
    totals = {int(r["step"]): int(r["segments"]) for _, r in by_step.iterrows()}
    rows = []
    layer = by_map["layer"].astype("Int64").astype(object).where(by_map["layer"].notna(), "none")
    for (step, name), frame in by_map.groupby([by_map["step"].astype(int), layer], sort=False):
        rows.append({"step": int(step), "layer": name if name == "none" else int(name),
                     "segments": int(frame["segments"].sum()), **classes(frame, totals[int(step)])})
    rows.sort(key=lambda r: (r["step"], r["layer"] == "none", r["layer"] if r["layer"] != "none" else 0))
    steps = []
    for index in by_step.sort_values("step").index:
        r = by_step.loc[index]
        steps.append({"step": int(r["step"]), "segments": int(r["segments"]),
                      **classes(by_step.loc[[index]], int(r["segments"])),
                      "abs_dt_mm": {q: _finite(1000.0 * float(r[f"abs_dt_{q}"])) for q in ("median", "p90", "p99")}})
    return {"rows": rows, "by_step": steps}


def power_budget(photons: pd.DataFrame) -> list:
    """Power by fate per (tracer, step), % of the power entering step 1."""
    out = []
    for _, r in photons.sort_values(["tracer", "step"]).iterrows():
        out.append({"tracer": r["tracer"], "step": int(r["step"]),
                    **{fate: 100.0 * float(r[f"share_{fate}"]) for fate in FATES},
                    "alive_after_last": _finite(100.0 * float(r["share_alive_after_last"]))})
    return out


def timing(e: Experiment) -> PassTiming:
    """One frame's time per pass (the experiment's timed frame with the median frame
    time, rendered without records) and its share of that frame; ``other``: the frame's
    time outside the passes (reading images back, the host's work)."""
    t = e.timings
    frame = t["frame_wall"]
    passes = [PassShare(name, t[name], t[name] / frame) for name in PASSES if name in t]
    other = max(frame - sum(p.seconds for p in passes), 0.0)
    passes.append(PassShare("other", other, other / frame))
    return PassTiming(e.cost.timing_method, frame, tuple(passes), PAPER_SHARES, e.timed_frames, e.gl_renderer,
                      e.map_reads)


def scene_page(result: SceneResult, *, exposures: dict) -> ScenePage:
    """Everything the page shows of one scene (``result``: ``reports.measuring.results.scene_result.SceneResult``)."""
    e = result.experiment
    components = {}
    for component in COLOUR_LAYERS:
        metrics = {name: find_estimate(e.images, name, component) for name in HEADLINE}
        # the floor over the compared pixels: what the debiased error had subtracted
        relmse = metrics["relative_mse"]
        components[component] = ComponentErrors(metrics, math.nan if relmse is None else relmse.reference_floor)
    rows = {r.term: r for r in e.decomposition}  # the report measures scope "full": a decomposition
    checks = sorted(result.checks, key=lambda c: (c.passed, c.name))
    params = e.params.to_dict()
    return ScenePage(
        scene=result.name, description=e.description, scene_hash=e.scene_hash, point=result.key,
        measured_in_this_run=result.measured, params=params, shown_params={k: params[k] for k in SHOWN_PARAMS},
        seed_values=tuple(e.seed_values), reference=e.reference, compared_pixels=e.compared_pixels,
        components=components,
        gate=SceneGate(None if not checks else all(c.passed for c in checks), result.gate_note, result.budgeted,
                       tuple(checks)),
        timing=timing(e), hit_classes=hit_classes(result.tables["segments"]),
        power_budget=tuple(power_budget(result.tables["photons"])),
        decomposition=PageDecomposition(tuple(rows[t] for t in TERMS), rows["total"], rows["noise"],
                                        cast("Closure", e.closure)),
        model=e.model, paths=dict(e.paths), exposure=exposures, warnings=tuple(e.warnings))


def scene_exposures(result: SceneResult) -> dict:
    """One exposure per shown component: the reference's (its bright pixels to 1)."""
    return exposures(result.views)


def report_summary(results: list, *, params: ApproxParams, seeds: int, reference_settings: ReferenceSettings,
                   budgets: dict, measurement: MeasurementSettings, baseline_dir: str | None,
                   clock: dict) -> ReportDocument:
    """The report's document of every scene's result; the studies' fields (the sweep, the
    animations, the comparisons, the frame check) empty: ``report_run`` fills those it was given."""
    pages = tuple(scene_page(r, exposures=scene_exposures(r)) for r in results)
    checks = [c for p in pages for c in p.gate.checks]
    failed = [c for c in checks if not c.passed]
    # a scene with budgets that could not be checked: the gate would fail closed (exit 2), never pass
    unchecked = tuple(p.scene for p in pages if p.gate.budgeted and not p.gate.checks)
    unbudgeted = tuple(p.scene for p in pages if not p.gate.budgeted)
    passed = False if failed else (None if unchecked or not checks else True)
    return ReportDocument(
        kind="accuracy report", created=time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        params=params.to_dict(), seeds=seeds, reference_settings=reference_settings.to_dict(),
        measurement=measurement.to_dict(), budgets=budgets["path"], baseline=baseline_dir,
        gate=GateSummary(passed, len(checks), len(failed), unchecked, unbudgeted),
        scales={name: scale.to_dict() for name, scale in SCALES.items()},
        exposure_rule="per scene and component: the reference's 99.5th percentile of lit luminance over the "
                      "compared pixels maps to 1 (metrics.image.reference_exposure); all images of that "
                      "component share it",
        scenes=pages, sweep=None,
        gl_renderers=tuple(sorted({str(r.experiment.gl_renderer) for r in results})),
        code_version=code_version(), versions=library_versions(), seconds=clock)
