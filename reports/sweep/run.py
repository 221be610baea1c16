"""Sweeps: a grid over the approximation's parameters, one experiment per point,
resumable in a store (``reports.store``), on local processes or Dask
(``reports.executors``).

A sweep is given on the command line (``--scenes a,b --vary layers=1,2,4 --set
photon_res=256 --seeds N``) or in a TOML file with the same names::

    scenes = ["bunny", "skull"]      # built-in names or .toml paths
    preset = "quick"                 # the parameters not named below
    seeds = 1
    [vary]                           # the grid: every combination, per scene
    layers = [1, 2, 4, 8]
    iterations = [4, 8, 16, 30]
    [set]                            # fixed parameters
    photon_res = 256
    [reference]                      # optional: the reference budget (report's by default)
    target_noise = "caustic=0.005,fog=0.002,direct=0.002"

Every name is an ``ApproxParams`` field (DESIGN.md); every point is validated before
anything renders. The reference of each scene (and image size) is rendered once, in
this process, before the points run; workers read it from the cache.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import threading
import time
from dataclasses import dataclass, field

from volcaustics.approx.params import ApproxParams, ParamError

from volcaustics.reports.core.store import TABLES

SPEC_KEYS = ("scenes", "preset", "seeds", "vary", "set", "reference")
MANIFEST = "sweep.json"  # the spec and the points the store's tables hold; written last
OUTPUT_FILES = (*(f"{name}.parquet" for name in (*TABLES, "points")), "suffice.csv", MANIFEST)
OUTPUT_FOLDERS = ("points", "figures")
REFERENCE_KEYS = ("photons", "spp", "batches", "target_noise", "max_photons", "max_seconds")


class SweepError(ValueError):
    """A sweep specification that cannot run; the message names where, what and the fix."""


@dataclass(frozen=True)
class SweepSpec:
    """scenes: SCENE arguments; vary: ((name, values), ...) in grid order; fixed:
    name → value; preset: "quick" or "paper"; seeds per point; reference: settings
    overrides (REFERENCE_KEYS)."""

    scenes: tuple
    vary: tuple
    fixed: dict = field(default_factory=dict)
    preset: str = "quick"
    seeds: int = 1
    reference: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"scenes": list(self.scenes), "vary": {k: list(v) for k, v in self.vary}, "set": dict(self.fixed),
                "preset": self.preset, "seeds": self.seeds, "reference": dict(self.reference)}


@dataclass(frozen=True)
class Point:
    scene: str          # the SCENE argument (built-in name or path)
    params: ApproxParams


# --- parsing -------------------------------------------------------------------------

def _field_types() -> dict:
    return {f.name: f.type for f in dataclasses.fields(ApproxParams)}


def parse_value(name: str, text, where: str):
    """A parameter value from text (CLI) or TOML, typed as ApproxParams declares it."""
    types = _field_types()
    if name not in types:
        raise SweepError(f"{where}: unknown parameter {name!r}; expected one of {', '.join(types)}")
    kind = str(types[name])
    if isinstance(text, str):
        text = text.strip()
    try:
        if "int" in kind:
            if isinstance(text, bool) or (isinstance(text, float) and not text.is_integer()):
                raise ValueError
            return int(text)
        if "float" in kind:
            if isinstance(text, bool):
                raise ValueError
            return float(text)
    except (TypeError, ValueError):
        raise SweepError(f"{where}: {name} = {text!r}: expected {'an integer' if 'int' in kind else 'a number'}") \
            from None
    if not isinstance(text, str) or not text:
        raise SweepError(f"{where}: {name} = {text!r}: expected a name")
    return text


def parse_assignment(text: str, where: str) -> tuple:
    """NAME=V1,V2 → (name, typed values); SweepError naming ``where`` otherwise."""
    name, sep, values = text.partition("=")
    name = name.strip().replace("-", "_")
    if not sep or not name:
        raise SweepError(f"{where} {text!r}: expected NAME=VALUE[,VALUE...]")
    items = values.split(",")
    if any(not v.strip() for v in items):
        raise SweepError(f"{where} {text!r}: an empty value")
    return name, [parse_value(name, v, where) for v in items]


def spec_from_args(scenes: str | None, vary: list, fixed: list, *, preset: str, seeds: int) -> SweepSpec:
    """A spec from ``--scenes a,b``, ``--vary NAME=V1,V2`` and ``--set NAME=V``."""
    from volcaustics.scenes import BUILTIN_NAMES

    names = [s.strip() for s in scenes.split(",")] if scenes is not None else list(BUILTIN_NAMES)
    grid, settled = [], {}
    for text in vary or []:
        name, values = parse_assignment(text, "--vary")
        if name in dict(grid):
            raise SweepError(f"--vary {text!r}: {name} is varied twice")
        grid.append((name, tuple(values)))
    for text in fixed or []:
        name, values = parse_assignment(text, "--set")
        if len(values) != 1:
            raise SweepError(f"--set {text!r}: one value (use --vary for several)")
        if name in settled:
            raise SweepError(f"--set {text!r}: {name} is set twice")
        settled[name] = values[0]
    return _checked(SweepSpec(tuple(names), tuple(grid), settled, preset, seeds), "command line")


def spec_from_toml(path: str) -> SweepSpec:
    """A spec from a TOML file (see the module's docstring)."""
    from volcaustics.reports.core.tomlfile import load_toml

    doc = load_toml(path, keys=SPEC_KEYS, error=SweepError, what="sweep spec")
    scenes = doc.get("scenes")
    if scenes is None:
        from volcaustics.scenes import BUILTIN_NAMES

        scenes = list(BUILTIN_NAMES)
    if not isinstance(scenes, list) or not all(isinstance(s, str) for s in scenes):
        raise SweepError(f"{path}: scenes = {scenes!r}: expected a list of scene names or paths")
    base = os.path.dirname(os.path.abspath(path))
    scenes = [s if not s.endswith(".toml") or os.path.isabs(s) else os.path.join(base, s) for s in scenes]
    grid = []
    for name, values in _table(doc, "vary", path).items():
        if not isinstance(values, list) or not values:
            raise SweepError(f"{path}: vary.{name} = {values!r}: expected a non-empty list")
        grid.append((name, tuple(parse_value(name, v, f"{path}: vary") for v in values)))
    settled = {name: parse_value(name, v, f"{path}: set") for name, v in _table(doc, "set", path).items()}
    reference = _table(doc, "reference", path)
    for key in reference:
        if key not in REFERENCE_KEYS:
            raise SweepError(f"{path}: reference.{key}: unknown; expected {', '.join(REFERENCE_KEYS)}")
    seeds = doc.get("seeds", 1)
    preset = doc.get("preset", "quick")
    return _checked(SweepSpec(tuple(scenes), tuple(grid), settled, preset, seeds, dict(reference)), path)


def _table(doc, key, path) -> dict:
    value = doc.get(key, {})
    if not isinstance(value, dict):
        raise SweepError(f"{path}: {key} = {value!r}: expected a table [{key}]")
    return value


def _checked(spec: SweepSpec, where: str) -> SweepSpec:
    """Validate everything that can be checked before rendering: scenes exist, names,
    the preset, the seeds, every point's parameters, overlaps of vary and set."""
    from volcaustics.approx.trace import check_fits
    from volcaustics.scenes import SceneError, resolve_scene

    if spec.preset not in ("quick", "paper"):
        raise SweepError(f"{where}: preset = {spec.preset!r}: expected \"quick\" or \"paper\"")
    if isinstance(spec.seeds, bool) or not isinstance(spec.seeds, int) or not 1 <= spec.seeds <= 1024:
        raise SweepError(f"{where}: seeds = {spec.seeds!r}: expected an integer in [1, 1024]")
    if not spec.scenes or any(not s for s in spec.scenes):
        raise SweepError(f"{where}: scenes = {list(spec.scenes)!r}: expected at least one scene, none empty")
    if len(set(spec.scenes)) != len(spec.scenes):
        raise SweepError(f"{where}: scenes = {list(spec.scenes)!r}: a scene is listed twice")
    for name, values in spec.vary:
        if len(set(values)) != len(values):
            raise SweepError(f"{where}: vary.{name} = {list(values)!r}: a value is listed twice")
    both = sorted(set(dict(spec.vary)) & set(spec.fixed))
    if both:
        raise SweepError(f"{where}: {both[0]} is both varied and set")
    if "seed" in dict(spec.vary):
        raise SweepError(f"{where}: seed cannot be varied; use seeds = N (points with seeds seed … seed + N − 1)")
    for scene in spec.scenes:
        try:
            resolve_scene(scene)
        except SceneError as exc:
            raise SweepError(f"{where}: {exc}") from None
    for point in points(spec):
        last = point.params.seed + spec.seeds - 1
        if last > 2**32 - 1:
            raise SweepError(f"{where}: seed {point.params.seed} with seeds = {spec.seeds} exceeds 2^32 − 1")
        try:  # what a frame allocates and dispatches, before any reference renders
            check_fits(point.params, keep_records=True)
        except ParamError as exc:
            raise SweepError(f"{where}: point {point.scene}: {exc}") from None
    return spec


def points(spec: SweepSpec) -> list:
    """Every point of the grid, per scene, in grid order (ParamError → SweepError)."""
    from volcaustics.approx.params import PAPER, QUICK

    try:
        base = dataclasses.replace({"quick": QUICK, "paper": PAPER}[spec.preset], **spec.fixed)
    except ParamError as exc:
        raise SweepError(f"set: {exc}") from None
    names = [name for name, _ in spec.vary]
    out = []
    for scene in spec.scenes:
        for combo in itertools.product(*(values for _, values in spec.vary)):
            changes = dict(zip(names, combo))
            try:
                params = dataclasses.replace(base, **changes)
            except ParamError as exc:
                raise SweepError(f"point {scene}, {changes}: {exc}") from None
            out.append(Point(scene, params))
    return out


# --- running -------------------------------------------------------------------------

def reference_settings(overrides: dict):
    """The reference budget: the report's, with ``overrides`` (REFERENCE_KEYS; a
    target_noise of "none" renders exactly ``batches``)."""
    from volcaustics.reference.settings import SettingsError

    from volcaustics.reports.core.sizing import REPORT_REFERENCE

    changes = dict(overrides)
    if isinstance(changes.get("target_noise"), str) and changes["target_noise"].strip().lower() == "none":
        changes["target_noise"] = None  # render exactly `batches` batches
    try:
        return dataclasses.replace(REPORT_REFERENCE, **changes) if changes else REPORT_REFERENCE
    except (SettingsError, TypeError) as exc:
        raise SweepError(f"reference: {exc}") from None


def run_point(task: dict) -> dict:
    """One point in a worker process (picklable: plain data in and out). Tasks of one
    process run one at a time, whatever the executor's threads (GL and Mitsuba are
    per process)."""
    with _PROCESS_LOCK:
        return _run_point(task)


def _run_point(task: dict) -> dict:
    from volcaustics.reference.cache import cached_reference
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.storage import cache_dir

    from volcaustics.reports.experiment.run import run_experiment
    from volcaustics.reports.core.store import Store

    t0 = time.perf_counter()
    store = Store(task["store"])
    if store.summary(task["key"]) is not None:
        return {"key": task["key"], "status": "done", "seconds": 0.0}
    scene = resolve_scene(task["scene"])
    params = ApproxParams(**task["params"])
    reference = cached_reference(task["reference_key"], scene)  # the sweep's own, never rendered here
    if reference is None:
        raise RuntimeError(f"{task['scene']}: reference {task['reference_key']} is not in this worker's cache "
                           f"({cache_dir('reference')}): the workers need the sweep's cache (VOLCAUSTICS_CACHE on "
                           f"a shared file system)")
    renderer, oracle = _worker_tools(scene)
    experiment = run_experiment(scene, params, seeds=task["seeds"], reference=reference, renderer=renderer,
                                oracle=oracle)
    status = store.write_point(task["key"], task["key_document"], experiment)
    return {"key": task["key"], "status": status, "seconds": time.perf_counter() - t0}


_PROCESS_LOCK = threading.Lock()
_TOOLS: dict = {}


def _worker_tools(scene) -> tuple:
    """A renderer and an oracle per scene, kept for the worker process's life (shader
    compilation and the oracle's scene build are paid once per scene)."""
    from volcaustics.approx import Renderer
    from volcaustics.reference.oracle import Oracle

    key = scene.scene_hash()
    if key not in _TOOLS:
        _TOOLS[key] = (Renderer(scene), Oracle(scene))
    return _TOOLS[key]


@dataclass
class SweepResult:
    total: int
    done_before: int
    computed: int
    failed: list
    seconds: float
    tables: dict
    figures: list
    point_seconds: list = field(default_factory=list)  # each computed point's own seconds, in its worker


def run_sweep(spec: SweepSpec, out_dir: str, *, workers: int | None = None, dask: str | None = None,
              progress: bool = True) -> SweepResult:
    """Run every point not yet in the store at ``out_dir``; then consolidate the tables
    and draw the figures. Ctrl-C stops it with the finished points kept."""
    import pandas as pd

    from volcaustics.reference.cache import existing_reference
    from volcaustics.reference.render import render_reference
    from volcaustics.scenes import resolve_scene

    from volcaustics.reports.core.executors import run_tasks
    from volcaustics.reports.sweep.figures import draw_figures, settings_that_suffice
    from volcaustics.reports.core.store import Store, key_document, point_key

    t0 = time.perf_counter()
    store = Store(out_dir)
    store.clean_stale()
    settings = reference_settings(spec.reference)
    grid = points(spec)
    scenes = {name: resolve_scene(name) for name in spec.scenes}
    references = {}
    tasks, keys = [], []
    for point in grid:
        scene = scenes[point.scene]
        p = point.params.resolved(scene)
        size = (point.scene, p.width, p.height)
        if size not in references:
            sized = dataclasses.replace(settings, width=p.width, height=p.height)
            # rendered once: an existing entry is used as it is (not continued), so a resumed
            # sweep measures against the reference its first points had
            references[size] = existing_reference(scene, sized) or render_reference(scene, sized, progress=progress)
        reference = references[size]
        document = key_document(scene, point.params, spec.seeds, reference)
        key = point_key(document)
        keys.append(key)
        if store.status(key) == "done":
            continue
        store.remove_damaged(key)
        tasks.append({"key": key, "key_document": document, "scene": point.scene, "params": p.to_dict(),
                      "seeds": spec.seeds, "reference_key": reference.key, "store": os.path.abspath(out_dir)})
    unique_tasks = list({t["key"]: t for t in tasks}.values())
    done_before = len(set(keys)) - len(unique_tasks)
    failed, computed, point_seconds = [], 0, []
    try:
        for result in run_tasks(run_point, unique_tasks, total=len(set(keys)), done=done_before, workers=workers,
                                dask=dask, progress=progress):
            if result.get("error"):
                failed.append(result)
            else:
                computed += 1
                point_seconds.append(result["seconds"])
    except BaseException:  # Ctrl-C: the stopped workers' half-written points go now, not on the next run
        store.clean_stale()
        raise
    varied = [name for name, _ in spec.vary]
    tables = store.tables(sorted(set(keys)))
    # no point finished: an empty table, never an earlier run's
    tables["suffice"] = settings_that_suffice(tables["points"], varied) if len(tables["points"]) else pd.DataFrame()
    manifest = {"spec": spec.to_dict(), "points": len(set(keys)), "keys": sorted(set(keys))}
    _write_tables(out_dir, tables, manifest)
    figures = draw_figures(tables, os.path.join(out_dir, "figures"), varied=varied)
    return SweepResult(total=len(set(keys)), done_before=done_before, computed=computed, failed=failed,
                       seconds=time.perf_counter() - t0, tables=tables, figures=figures, point_seconds=point_seconds)


def _write_tables(out_dir: str, tables: dict, manifest: dict) -> None:
    """The consolidated tables, suffice.csv and, last, sweep.json as one set
    (``scenes.storage.atomic_set``): an interrupted sweep leaves the last complete set,
    never a manifest beside another run's tables (what ``report --sweep`` reads)."""
    import json

    from volcaustics.scenes.storage import atomic_set

    names = [name for name in OUTPUT_FILES if name != MANIFEST]
    with atomic_set([os.path.join(out_dir, name) for name in (*names, MANIFEST)]) as temps:
        for name, tmp in zip(names, temps):
            if name == "suffice.csv":
                tables["suffice"].to_csv(tmp, index=False)
            else:
                tables[name[: -len(".parquet")]].to_parquet(tmp, index=False)
        with open(temps[-1], "w", encoding="utf-8") as fh:
            fh.write(json.dumps(manifest, indent=1))
