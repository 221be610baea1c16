"""The best-configuration search's spec (``reports/studies/best/best.toml``, or another file):
its axes, seeds, rounds and criteria, checked before anything renders."""

from __future__ import annotations

import dataclasses
import os

from volcaustics.approx.params import PRESETS
from volcaustics.reports.measuring.results.param_input import parse_value
from volcaustics.reports.measuring.results.tomlfile import load_toml
from volcaustics.reports.studies.sweep.sweep_spec import SweepError, SweepSpec, checked_spec, spec_scenes

BEST_SPEC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "best.toml")
BEST_KEYS = ("scenes", "preset", "seeds", "coarse", "refine", "rounds", "set", "reference", "measurement")


@dataclasses.dataclass(frozen=True)
class BestSpec:
    """scenes; preset (the paper configuration at the harness's size); seeds per point;
    coarse, refine: ((name, values), ...); rounds of refinement; reference overrides;
    fixed: parameters set on the preset (the paper configuration's too, e.g. a smaller
    image)."""

    scenes: tuple
    preset: str
    seeds: int
    coarse: tuple
    refine: tuple
    rounds: int
    reference: dict
    fixed: dict = dataclasses.field(default_factory=dict)
    measurement: dict = dataclasses.field(default_factory=dict)  # the measurement settings' overrides

    @property
    def searched(self) -> tuple:
        """The searched parameters' names, coarse then refine."""
        return tuple(dict.fromkeys([n for n, _ in self.coarse] + [n for n, _ in self.refine]))

    def sweep_spec(self) -> SweepSpec:
        """As a sweep spec (its grids: the coarse grid and each refine axis alone), for
        validation and the manifest."""
        grids = (self.coarse, *(((name, values),) for name, values in self.refine))
        merged: dict = {}
        for grid in grids:
            for name, values in grid:
                merged.setdefault(name, [])
                merged[name] += [v for v in values if v not in merged[name]]
        return SweepSpec(self.scenes, tuple((n, tuple(v)) for n, v in merged.items()), dict(self.fixed), self.preset,
                         self.seeds, dict(self.reference), grids, dict(self.measurement))


def load_best_spec(path: str = BEST_SPEC, scenes: list | None = None) -> BestSpec:
    """The spec at ``path`` (SweepError naming the file, key and value otherwise);
    ``scenes`` replaces its scenes."""
    doc = load_toml(path, keys=BEST_KEYS, what="best-configuration spec")
    axes: dict = {}
    for key in ("coarse", "refine"):
        table = doc.get(key, {})
        if not isinstance(table, dict):
            raise SweepError(f"{path}: {key} = {table!r}: expected a table [{key}]")
        if key in doc and not table:
            raise SweepError(f"{path}: [{key}] is empty: give its axes (NAME = [values]) or leave the table out")
        axes[key] = []
        for name, values in table.items():
            if name in ("photon_res", "seed"):
                raise SweepError(f"{path}: {key}.{name}: {name} is not searched (photon_res matches the cost; seeds "
                                 f"= N sets the seeds)")
            if not isinstance(values, list) or not values:
                raise SweepError(f"{path}: {key}.{name} = {values!r}: expected a non-empty list")
            parsed = tuple(parse_value(name, v, f"{path}: {key}") for v in values)
            if len(set(parsed)) != len(parsed):  # named here: the sweep's own check says vary.NAME
                raise SweepError(f"{path}: {key}.{name} = {values!r}: a value is listed twice")
            axes[key].append((name, parsed))
    both = set(dict(axes["coarse"])) & set(dict(axes["refine"]))
    if both:
        raise SweepError(f"{path}: {sorted(both)[0]} is in both [coarse] and [refine]: search it in one of them")
    if not axes["coarse"] and not axes["refine"]:  # it searched nothing, over every built-in, for hours
        raise SweepError(f"{path}: no [coarse] or [refine] axis: nothing to search; give at least one, e.g. "
                         f"[coarse] layers = [2, 4]")
    rounds = doc.get("rounds", 1)
    if isinstance(rounds, bool) or not isinstance(rounds, int) or not 0 <= rounds <= 10:
        raise SweepError(f"{path}: rounds = {rounds!r}: expected an integer in [0, 10]")
    names = spec_scenes(doc, path, scenes)
    fixed = doc.get("set", {})
    if not isinstance(fixed, dict):
        raise SweepError(f"{path}: set = {fixed!r}: expected a table [set]")
    fixed = {name: parse_value(name, v, f"{path}: set") for name, v in fixed.items()}
    searched = [n for n, _ in axes["coarse"] + axes["refine"]]
    if set(fixed) & set(searched):
        raise SweepError(f"{path}: {sorted(set(fixed) & set(searched))[0]} is both searched and set")
    reference = doc.get("reference", {})
    if not isinstance(reference, dict):
        raise SweepError(f"{path}: reference = {reference!r}: expected a table [reference]")
    spec = BestSpec(tuple(names), doc.get("preset", "quick"), doc.get("seeds", 4), tuple(axes["coarse"]),
                    tuple(axes["refine"]), rounds, dict(reference), fixed, doc.get("measurement", {}))
    if spec.preset not in PRESETS:
        raise SweepError(f"{path}: preset = {spec.preset!r}: expected {' or '.join(repr(n) for n in PRESETS)}")
    checked_spec(spec.sweep_spec(), path)
    return spec


# --- the search -------------------------------------------------------------------------
