"""The best-configuration search (``volcaustics sweep --best``, ``make sweep-best``): which
configuration of the whole method gives the least caustic
error for the paper configuration's frame cost, on every built-in.

Method (``reports/studies/best/best.toml`` states the axes):

1. **Equal cost by construction.** Every configuration is measured at the
   ``photon_res`` that makes its frame cost (``approx.cost``: map reads + emission
   reads + splats, hardware-independent) at most the paper configuration's on that
   scene, at the first seed (:class:`CostMatcher`: photon_res ← photon_res·√(target /
   cost), re-rendered until it stays, then lowered 1% at a time until within). So a
   configuration that reads more per segment or spends photons better pays with fewer
   photons, and ``photon_res`` is not searched: it is the cost.
2. **Coarse grid:** every combination of the ``coarse`` axes on every scene.
3. **Refinement** around the adopted configuration: the one whose *worst* ratio over
   the scenes (the criterion's: ``frame``, one frame's caustic relative MSE,
   ``metrics.frame``; ``bias``, the seeds' mean's, debiased; against the paper's) is
   least, among
   those measured on every scene. Each ``refine`` axis is moved one value at a time
   from it, on every scene; a better worst ratio is adopted and its neighbours tried,
   for ``rounds`` rounds (coordinate descent). With cost matched, each scene's Pareto
   front of (cost, error) is the least error at the paper's cost: the refinement is
   around it.

The result is one table (``best.parquet``): every point with its configuration, cost
against the paper's, caustic relMSE and every decomposition term's energy share and
relMSE part, and its ``role``: ``paper``, ``adopted`` (the one configuration for every
scene) and ``scene best`` (each scene's own least error at ≤ the paper's cost).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from tqdm import tqdm

from volcaustics.approx.params import ParamError, preset
from volcaustics.experiment.measurement import measurement_settings
from volcaustics.experiment.result import Estimate
from volcaustics.experiment.sizing import reference_settings
from volcaustics.infra.folder_lock import folder_lock
from volcaustics.metrics.decomposition import TERMS
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.cost_match import CostMatcher
from volcaustics.reports.measuring.results.store import Store
from volcaustics.reports.studies.best.best_spec import BestSpec
from volcaustics.reports.studies.sweep.study_limits import CRITERIA
from volcaustics.reports.studies.sweep.sweep_run import consolidate
from volcaustics.reports.studies.sweep.sweep_spec import SweepError

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams


def configuration(params: ApproxParams, names: Iterable[str]) -> tuple:
    """The searched parameters' values of ``params``, as a hashable key."""
    return tuple((name, getattr(params, name)) for name in names)


def config_label(config: tuple, base: ApproxParams) -> str:
    """What a configuration changes from the paper's ("paper" for none)."""
    changed = [f"{name}={value}" for name, value in config if getattr(base, name) != value]
    return ", ".join(changed) or "paper"


@dataclasses.dataclass
class BestSearch:
    """The state of one search: the spec, its store and every point measured so far."""

    spec: BestSpec
    out_dir: str
    workers: int | None = None
    dask: str | None = None
    progress: bool = True
    criterion: str = "frame"

    def __post_init__(self):
        self.base = preset(self.spec.preset, **self.spec.fixed)
        self.store = Store(self.out_dir)
        self.matcher = CostMatcher(self.out_dir)
        self.points = {}        # (scene, config) → Point
        self.keys = {}          # (scene, config) → store key
        self.targets = {}       # scene → the paper configuration's cost at the first seed
        self.failed = []

    def run_configs(self, configs: list, desc: str) -> None:
        """Measure every configuration of ``configs`` (dicts name → value) on every scene."""
        todo = []
        names = self.spec.searched
        for scene in self.spec.scenes:
            if scene not in self.targets:
                self.targets[scene] = self.matcher.cost(scene, self.base)
            for changes in tqdm(configs, desc=f"{desc}: matching cost on {scene}", unit="config",
                                disable=not self.progress):
                try:
                    params = dataclasses.replace(self.base, **changes)
                except ParamError as exc:
                    raise SweepError(f"{desc}: {changes}: {exc}") from None
                config = configuration(params, names)
                if (scene, config) in self.points:
                    continue
                if config != configuration(self.base, names):
                    params = self.matcher.match(scene, params, self.targets[scene])
                self.points[(scene, config)] = runner.Point(scene, params, self.spec.seeds)
                todo.append((scene, config))
            self.matcher.save()
        run = runner.measure([self.points[k] for k in todo], self.store,
                             reference_settings=reference_settings(self.spec.reference),
                             measurement=measurement_settings(self.spec.measurement),
                             policy="missing", workers=self.workers, dask=self.dask, progress=self.progress,
                             read_back=False)
        self.keys.update(dict(zip(todo, run.keys)))
        self.failed += run.failed

    def table(self) -> pd.DataFrame:
        """One row per measured point (module docstring), ``role`` still empty."""
        rows = []
        for (scene, config), key in self.keys.items():
            e = self.store.experiment(key)
            if e is None:
                continue  # failed
            caustic, frame = e.metric("relative_mse"), e.find_metric("frame_relative_mse") or Estimate(np.nan)
            terms = {r.term: r for r in e.decomposition}
            row = {"scene": e.scene, "scene_arg": scene, "point": key,
                   "config": config_label(config, self.base), **e.params.to_dict(),
                   "frame_cost": e.cost.counted, "splats_per_frame": e.cost.splats,
                   **{f"predicted_{name}": v for name, v in e.cost.predicted.items()},
                   "map_reads_per_frame": e.cost.map_reads, "emission_reads_per_frame": e.cost.emission_reads,
                   "frame_time_s": e.timings.get("frame_wall"),
                   "caustic_relmse_debiased": caustic.debiased, "caustic_relmse_se": caustic.standard_error,
                   "caustic_relmse_ci_low": caustic.ci_low, "caustic_relmse_ci_high": caustic.ci_high,
                   "frame_relmse": frame.debiased, "frame_relmse_se": frame.standard_error}
            for term in TERMS:
                row[f"share_{term}"] = terms[term].energy_share if term in terms else None
                row[f"relmse_{term}"] = terms[term].relmse_part_debiased if term in terms else None
            rows.append(row)
        table = pd.DataFrame(rows)
        return with_ratios(table, self.base) if len(table) else table

    def adopted(self, table: pd.DataFrame) -> str | None:
        """The configuration (label) with the least worst ratio over the scenes, among
        those measured on every scene; None without one."""
        worst = worst_ratios(table, len(self.spec.scenes), CRITERIA[self.criterion][0])
        return None if worst.empty else worst.idxmin()


def with_ratios(table: pd.DataFrame, base: ApproxParams) -> pd.DataFrame:
    """Per row: ``cost_ratio`` (the largest predicted ratio over the cost model's weight
    sets; the counted total's without them), ``time_ratio`` (measured frame time),
    ``relmse_ratio`` (debiased caustic relMSE) and ``frame_ratio`` (one frame's) against
    its scene's paper point."""
    table = table.copy()
    predicted = [c for c in table.columns if c.startswith("predicted_")] or ["frame_cost"]
    table["cost_ratio"] = np.nan
    table["time_ratio"] = np.nan
    table["relmse_ratio"] = np.nan
    table["frame_ratio"] = np.nan
    for _, own in table.groupby("scene"):
        paper = own[own["config"] == "paper"]
        if paper.empty:
            continue
        paper = paper.iloc[0]
        table.loc[own.index, "cost_ratio"] = pd.concat([own[c] / paper[c] for c in predicted], axis=1).max(axis=1)
        if "frame_time_s" in own:  # measured by each point's own timed frames
            table.loc[own.index, "time_ratio"] = own["frame_time_s"] / paper["frame_time_s"]
        # a debiased relMSE below 0 is an error within the noise: 0
        table.loc[own.index, "relmse_ratio"] = (own["caustic_relmse_debiased"].clip(lower=0.0)
                                                / paper["caustic_relmse_debiased"])
        if "frame_relmse" in own:  # one frame's error: bias and noise, never below 0 in expectation
            table.loc[own.index, "frame_ratio"] = own["frame_relmse"] / paper["frame_relmse"]
    return table


def worst_ratios(table: pd.DataFrame, scenes: int, ratio: str = "relmse_ratio") -> pd.Series:
    """Per configuration measured on all ``scenes`` scenes and within the paper's cost on
    each: its largest ``ratio`` (relmse_ratio: the debiased caustic relMSE's; frame_ratio:
    one frame's)."""
    if table.empty:
        return pd.Series(dtype=float)
    table = table[table["cost_ratio"] <= 1.0 + COST_SLACK]
    grouped = table.groupby("config")[ratio]
    worst = grouped.max()[grouped.count() == scenes]
    return worst.dropna()


def with_roles(table: pd.DataFrame, adopted: str | None, criterion: str = "bias") -> pd.DataFrame:
    """``role`` per row: "paper", "adopted", "scene best" (the least error by
    ``criterion`` at ≤ the paper's cost on its scene; a row may be "adopted, scene
    best"), else ""."""
    error = CRITERIA[criterion][1]
    table = table.copy()
    roles = pd.Series("", index=table.index, dtype=object)
    for _, own in table.groupby("scene"):
        within = own[own["cost_ratio"] <= 1.0 + COST_SLACK]
        for index in own.index:
            parts = []
            if own.at[index, "config"] == "paper":
                parts.append("paper")
            if adopted is not None and own.at[index, "config"] == adopted:
                parts.append("adopted")
            if len(within) and index == within[error].idxmin():
                parts.append("scene best")
            roles[index] = ", ".join(parts)
    table["role"] = roles
    table["criterion"] = criterion  # what the search ranked by (the report's verdict reads it back)
    return table.sort_values(["scene", CRITERIA[criterion][0]]).reset_index(drop=True)


# The cost is matched at the first seed; the mean over the seeds may exceed the paper's by its
# seed-to-seed spread (docs/decisions.md "The best-configuration search": at most +0.11% measured).
COST_SLACK = 0.01


def neighbours(config: dict, refine: tuple) -> list:
    """``config`` with one refine axis moved to each of its other values."""
    out = []
    for name, values in refine:
        for value in values:
            if config.get(name) != value:
                out.append({**config, name: value})
    return out


@dataclasses.dataclass
class BestResult:
    """A search's outcome: every point with its role, the adopted configuration's label (or
    None), whether it meets the criterion's goal (:func:`verdict`), the failed points, the
    store keys of every point, and the seconds it took."""

    table: pd.DataFrame
    adopted: str | None
    verdict: dict
    failed: list
    keys: list
    seconds: float


def run_best(spec: BestSpec, out_dir: str, *, workers: int | None = None, dask: str | None = None,
             progress: bool = True, criterion: str = "frame") -> BestResult:
    """The search (module docstring) by ``criterion`` (CRITERIA), its points in the store at
    ``out_dir`` and, consolidated there as a sweep's, their tables with ``best.parquet`` and
    the verdict in the manifest. The folder is the search's for the whole run, as a sweep's
    (``infra.folder_lock``)."""
    t0 = time.perf_counter()
    with folder_lock(out_dir, what="sweep --best"):
        table, adopted, failed, keys = _search(spec, out_dir, workers=workers, dask=dask, progress=progress,
                                               criterion=criterion)
        if table.empty:  # nothing measured: no roles, verdict or tables to write
            return BestResult(table, None, {}, failed, keys, time.perf_counter() - t0)
        result = verdict(table, adopted, criterion)
        consolidate(Store(out_dir), out_dir, spec.sweep_spec(), sorted(set(keys)), extra={"best": table},
                    manifest={"best": result})
    return BestResult(table, adopted, result, failed, keys, time.perf_counter() - t0)


def _search(spec: BestSpec, out_dir: str, *, workers, dask, progress: bool, criterion: str) -> tuple:
    """(table with roles, the adopted configuration's label or None, failed points, every
    point's store key)."""
    search = BestSearch(spec, out_dir, workers=workers, dask=dask, progress=progress, criterion=criterion)
    try:
        coarse = [dict(zip([n for n, _ in spec.coarse], combo))
                  for combo in itertools.product(*(values for _, values in spec.coarse))]
        search.run_configs(coarse, "coarse grid")
        table = search.table()
        adopted = search.adopted(table)
        for round_ in range(spec.rounds):
            if adopted is None:
                break
            labels = {config_label(config, search.base): dict(config) for _, config in search.points}
            search.run_configs(neighbours(labels[adopted], spec.refine), f"refinement {round_ + 1}")
            table = search.table()
            better = search.adopted(table)
            if better == adopted:
                break
            adopted = better
    finally:
        search.matcher.release()
    keys = list(search.keys.values())
    return (table if table.empty else with_roles(table, adopted, criterion)), adopted, search.failed, keys


def verdict(table: pd.DataFrame, adopted: str | None, criterion: str = "bias") -> dict:
    """Whether the adopted configuration meets ``criterion``'s goal (CRITERIA) on every
    scene at ≤ the paper's cost, with its worst and per-scene factors by both criteria."""
    ratio, _, goal = CRITERIA[criterion]
    if adopted is None or table.empty:
        return {"adopted": None, "met": False, "goal": goal, "criterion": criterion}
    own = table[table["config"] == adopted]
    per_scene = {r["scene"]: {"relmse_ratio": r["relmse_ratio"], "frame_ratio": r.get("frame_ratio"),
                              "cost_ratio": r["cost_ratio"]} for _, r in own.iterrows()}
    worst = float(own[ratio].max())
    within_cost = bool((own["cost_ratio"] <= 1.0 + COST_SLACK).all())
    out = {"adopted": adopted, "criterion": criterion, "goal": goal, "worst_ratio": worst,
           "within_cost": within_cost, "met": bool(worst <= goal and within_cost), "per_scene": per_scene}
    for name, (column, _, _) in CRITERIA.items():
        if column in own:
            out[f"worst_{name}_ratio"] = float(own[column].max())
    return out
