"""The one measurement runner (docs/architecture.md): points → references by a stated policy
(rendered on the executor's pool when there is one) → result-store lookup → experiments on
an executor → results. ``measure``, the sweep, the gate, the report and the frame check
(``reports.studies.best.frame_check``, into a store in its folder) measure through it;
``animate`` measures its animations through :func:`measure_set` into the same result
store (sealed sets, ``reports.measuring.results.sealed_sets``: read back, never measured
twice), with its references from here.

A point is a scene, the approximation's parameters and a number of seeds. Its key
(``reports.measuring.results.store.point_key``) hashes everything that determines its result, so
a point any command has stored is never measured again: the gate right after the
report reads the report's results.

Reference policies:

* ``cached`` — the cached reference as it is; a missing one is an error (the gate
  without ``--render-references``);
* ``missing`` — the cached reference as it is, a missing one rendered (a sweep: a
  resumed sweep measures against the reference its first points had);
* ``continue`` — rendered to the budget: a cached entry that does not meet it is
  continued batch by batch (the report, ``measure``).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

import pandas as pd
from tqdm import tqdm

from volcaustics.approx import Renderer
from volcaustics.approx.cost_model import weight_sets
from volcaustics.approx.params import ApproxParams
from volcaustics.experiment.measurement import MeasurementSettings
from volcaustics.experiment.pipeline import run_experiment
from volcaustics.experiment.point_checks import measurement_bytes
from volcaustics.experiment.result import Experiment
from volcaustics.experiment.sizing import sized
from volcaustics.experiment.summaries import ExperimentSummary
from volcaustics.infra.errors import InputError
from volcaustics.infra.memory import memory_budget
from volcaustics.infra.storage import CacheError, cache_dir, cache_path
from volcaustics.reference.cache import ReferenceResult, cached_reference, existing_reference
from volcaustics.reference.oracle import Oracle
from volcaustics.reference.render import render_references
from volcaustics.reference.render.tasks import PROCESS_LOCK
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.measuring.pools.executors import default_workers, disk_full, open_pool, run_tasks
from volcaustics.reports.measuring.results.sealed_sets import complete_set, write_set
from volcaustics.reports.measuring.results.store import IMAGE_FILES, TABLES, Store, key_document, point_key
from volcaustics.reports.measuring.results.tables import rows_of
from volcaustics.scenes import resolve_scene
from volcaustics.scenes.fields import scene_with
from volcaustics.scenes.portable import packed, unpacked

if TYPE_CHECKING:
    from volcaustics.reports.measuring.pools.executors import Pool
    from volcaustics.scenes.model import Scene

POLICIES = ("cached", "missing", "continue")
RESULTS_STORE = "report-results"  # $VOLCAUSTICS_CACHE/report-results: the report's and the gate's results


class RunnerError(InputError):
    """A point that cannot be measured here (a missing reference under ``cached``)."""


def results_store() -> Store:
    """The result store ``measure``, the report and the gate share (with the views a report
    shows). A read-only cache serves the points it holds; measuring a point there is refused
    before it starts (:func:`measure`)."""
    folder = cache_path(RESULTS_STORE)
    return Store(folder if os.path.isdir(folder) else cache_dir(RESULTS_STORE))  # made, or CacheError


@dataclass(frozen=True)
class Point:
    scene: str               # the SCENE argument (built-in name or path)
    params: ApproxParams     # unresolved: width/height unset take the scene camera's
    seeds: int = 1           # frames with seeds params.seed … params.seed + seeds − 1
    fields: tuple = ()       # scene fields changed: ((dotted path, value), ...) (scenes.fields)
    # the scene already resolved from ``scene`` and ``fields`` (None: the runner resolves it),
    # so that a command resolves it once; it travels with the point to this process's work
    resolved: Scene | None = field(default=None, compare=False, repr=False)


def point_scene(scene: str, fields: tuple = ()) -> Scene:
    """The scene of a point: the SCENE argument with its changed fields."""
    return cast("Scene", scene_with(scene, fields)) if fields else resolve_scene(scene)


# The version of a point task's fields: a worker of another volcaustics (a Dask cluster whose
# machines were not all updated) refuses a task of another version rather than misread it.
# 2: the key document carries the run's reference request (``reference_request``).
TASK_VERSION = 2


@dataclass(frozen=True)
class PointTask:
    """What a process needs to measure one point not in the store (plain data, picklable):
    the point's key and the document it hashes, its scene (SCENE argument and changed
    fields), its resolved parameters and measurement settings as dicts, the reference's
    cache key, the store's folder and the optional images to store (``store.IMAGE_FILES``).
    A shipped task's reference and scene go beside it (:func:`run_point`'s ``payload``)."""

    key: str
    key_document: dict
    scene: str
    params: dict             # ApproxParams.to_dict(), resolved
    seeds: int
    reference_key: str
    store: str               # the store's folder (absolute)
    measurement: dict = field(default_factory=lambda: MeasurementSettings().to_dict())
    fields: tuple = ()       # ((dotted path, value), ...)
    images: tuple = ()
    version: int = TASK_VERSION


@dataclass
class PointResult:
    """One point as the store holds it (``tables``: "segments", "photons", "images" →
    DataFrame; ``views`` and ``layers``: name → image, when the run asked for them:
    ``store.IMAGE_FILES``)."""

    point: Point
    key: str
    summary: ExperimentSummary
    tables: dict
    views: dict
    measured: bool           # measured in this run (False: from the store)
    layers: dict = field(default_factory=dict)
    experiment: Experiment = field(init=False, repr=False)  # the summary read once, typed (attributes from here)

    def __post_init__(self) -> None:
        self.experiment = Experiment.from_summary(self.summary, key=self.key, tables=self.tables)

    @property
    def segments(self) -> list:
        return rows_of(self.tables["segments"])


@dataclass
class Measured:
    """What a run did: ``results`` per point in order (read back when asked), the keys,
    how many were in the store before, computed now, or failed (with the error)."""

    keys: list
    done_before: int
    computed: int
    failed: list
    seconds: float
    point_seconds: list = field(default_factory=list)   # each computed point's own seconds
    results: list = field(default_factory=list)


@dataclass(frozen=True)
class StoredSet:
    """A study's result kept as a sealed set (``results.sealed_sets``): its summary, its
    folder in the store, and whether this call measured it (False: read back)."""

    summary: dict
    folder: str
    measured: bool


def measure_set(store: Store, folder: str, key: str, kind: str, measure: Callable[[str], dict]) -> StoredSet:
    """A study's result that is not a point (an animation) under ``key`` in the store's
    ``folder``: read back when a complete, undamaged set is there, else measured once by
    ``measure(into)`` (which writes its files into the fresh folder ``into`` and returns
    its summary of ``kind``) and stored whole."""
    where = os.path.join(store.root, folder, key)
    summary = complete_set(where, key, kind)
    if summary is not None:
        return StoredSet(summary, where, False)
    if not os.access(store.root, os.W_OK | os.X_OK):  # before anything is measured
        raise CacheError(f"result store {store.root} is not a writable folder, and this {kind} is not in it: make it "
                         f"writable, or point VOLCAUSTICS_CACHE at a writable folder")
    return StoredSet(write_set(where, key, kind, measure), where, True)


def reference_for(scene: Scene, settings: ReferenceSettings, policy: str, *, progress: bool = False,
                  hint: str = "") -> ReferenceResult:
    """The reference of ``scene`` at ``settings`` (already sized) under ``policy``."""
    return references_for({0: (scene, settings)}, policy, progress=progress, hint=hint)[0]


def references_for(wanted: dict, policy: str, *, progress: bool = False, hint: str = "",
                   pool: Pool | None = None) -> dict:
    """The reference of every entry of ``wanted`` (name → (scene, settings already
    sized)) under ``policy``, by name. Those to render render together: on ``pool``
    (``executors.open_pool``) their batches go to its workers at once."""
    if policy not in POLICIES:
        raise ValueError(f"policy = {policy!r}: expected one of {', '.join(POLICIES)}")
    out, render = {}, []
    for name, (scene, settings) in wanted.items():
        found = None if policy == "continue" else existing_reference(scene, settings)
        if found is None and policy == "cached":
            size = f"{settings.width}x{settings.height}" if settings.width else "the scene's size"
            raise RunnerError(f"{scene.name}: no reference in the cache for {size}" + (f": {hint}" if hint else ""))
        if found is None:
            render.append(name)
        else:
            out[name] = found
    jobs = [(*wanted[name], "caustic") for name in render]
    out.update(zip(render, render_references(jobs, progress=progress, pool=pool)))
    return out


def measure(points: list, store: Store, *, reference_settings: ReferenceSettings, measurement: MeasurementSettings,
            policy: str, images: tuple = (), workers: int | None = None, dask: str | None = None,
            parallel: bool = False, progress: bool = True, read_back: bool = True, hint: str = "") -> Measured:
    """Measure every point not in ``store`` yet and return them all.

    References are resolved once per scene and image size before any point runs: those
    to render render in this process, or with ``workers`` or ``dask`` batch by batch on
    the pool the points then run on (``reports.measuring.pools.executors``; stored by this process).
    ``measurement``: how every point is measured (its settings are part of each point's
    key). Points run in this process one after another (``workers`` and ``dask`` None) or
    on that pool (a sweep: a failed point is reported in ``failed``, the others go on; a
    reference whose batch fails raises ``BatchError``). ``parallel`` (the report, the gate): more than one
    point to measure run on local processes, one per core as far as their images fit the
    memory together (:func:`_parallel_processes`), and a failed point raises RunnerError as
    in this process. ``images``: which optional images the store keeps and the results
    read back (``store.IMAGE_FILES``: "views", the images a report shows; "layers", the
    decomposition's); a point stored without them counts as missing.
    ``read_back``: ``results`` holds every point as the store has it."""
    t0 = time.perf_counter()
    weight_sets()  # every point prices its frame with them: a damaged weight file is refused before any render
    store.clean_stale()
    pooled = workers is not None or dask is not None
    with open_pool(workers=workers, dask=dask) if pooled else contextlib.nullcontext() as pool:
        tasks, keys, references, scenes = _tasks(points, store, reference_settings, measurement, policy,
                                                 images=images, progress=progress, hint=hint, pool=pool)
        unique = list({t.key: t for t in tasks}.values())
        if unique and not os.access(store.points, os.W_OK | os.X_OK):  # before anything is measured
            raise CacheError(f"result store {store.root} is not a writable folder, and {len(unique)} point(s) are "
                             f"not in it with the images asked for: make it writable, or point VOLCAUSTICS_CACHE (the "
                             f"store of measure, the report and the gate) or a sweep's -o at a writable folder")
        done_before = len(set(keys)) - len(unique)
        count = {"total": len(set(keys)), "done": done_before, "progress": progress}
        processes = _parallel_processes(unique) if parallel and not pooled else 1
        if processes > 1:
            with open_pool(workers=processes) as local:
                outcomes = _on_executor(unique, store, local, desc="experiments", **count)
            scene_of = {task.key: task.scene for task in unique}
            for outcome in outcomes:
                if outcome.get("error"):
                    failure = outcome["error"]
                    raise RunnerError(f"{scene_of[outcome['key']]}: its point failed on a worker process: {failure}")
        elif pool is None:  # this process: the references as resolved (rendered or cached)
            outcomes = [run_point(task, progress=progress, reference=references[task.reference_key],
                                  scene=scenes[task.key])
                        for task in tqdm(unique, desc="experiments", unit="point", disable=not progress)]
        elif dask is not None:  # machines that may share no disk: the reference goes out, the point comes back
            payloads = [{"reference": (task.reference_key, references[task.reference_key]),
                         "scene_package": (task.key_document["scene_hash"], packed(scenes[task.key]))}
                        for task in unique]
            outcomes = _on_executor(unique, store, pool, payloads=payloads, **count)
        else:
            outcomes = _on_executor(unique, store, pool, **count)
    failed = [o for o in outcomes if o.get("error")]
    done = [o for o in outcomes if not o.get("error")]
    computed = {o["key"] for o in done}
    results = [_read_back(store, point, key, images, key in computed)
               for point, key in zip(points, keys)] if read_back else []
    return Measured(keys=keys, done_before=done_before, computed=len(done), failed=failed,
                    seconds=time.perf_counter() - t0, point_seconds=[o["seconds"] for o in done], results=results)


def _parallel_processes(tasks) -> int:
    """How many local processes measure ``tasks`` at once: one per core, at most as many
    as there are tasks, and only as many as the largest point's images fit the memory
    budget together (``check_frame`` lets one point have the whole budget)."""
    need = max((measurement_bytes(t.params["width"], t.params["height"], t.seeds) for t in tasks), default=1)
    return max(1, min(default_workers(), len(tasks), memory_budget() // need))


def _tasks(points, store, settings, measurement, policy, *, images, progress, hint, pool) -> tuple:
    """The :class:`PointTask` of every point not done, every point's key, the references
    by key (rendered on ``pool`` when it is not None) and the tasks' scenes by key."""
    wanted: dict
    scenes, wanted, sizes = {}, {}, []
    for point in points:
        if (point.scene, point.fields) not in scenes:
            scenes[(point.scene, point.fields)] = point.resolved or point_scene(point.scene, point.fields)
        scene = scenes[(point.scene, point.fields)]
        sized_settings = sized(settings, scene, point.params)
        size = (point.scene, point.fields, sized_settings.width, sized_settings.height)
        wanted.setdefault(size, (scene, sized_settings))
        sizes.append(size)
    references = references_for(wanted, policy, progress=progress, hint=hint, pool=pool)
    tasks, keys, task_sizes = [], [], []
    for point, size in zip(points, sizes):
        scene, reference = wanted[size][0], references[size]
        document = {**key_document(scene, point.params, point.seeds, reference, wanted[size][1]),
                    **measurement.to_dict()}
        key = point_key(document)
        if measurement.scope != "full":  # a full point (the report's) holds all a gate point would
            full = point_key({**document, "scope": "full"})
            key = full if store.status(full, images=images) == "done" else key
        keys.append(key)
        held = store.stored_images(key)  # the point's files read (and hashed) once
        if held is not None and set(images) <= set(held):  # done
            continue
        # a complete point without the images asked for is measured again with its own too,
        # and stays until its replacement is in place: the report's views and measure's
        # layers do not push each other out of the store, nor does a failed measurement
        kept = held or ()
        if held is None:
            store.remove_damaged(key)
        task_sizes.append(size)
        tasks.append(PointTask(key=key, key_document=document, scene=point.scene, fields=tuple(point.fields),
                               measurement=measurement.to_dict(), params=point.params.resolved(scene).to_dict(),
                               seeds=point.seeds, reference_key=reference.key, store=os.path.abspath(store.root),
                               images=tuple(n for n in IMAGE_FILES if n in {*images, *kept})))
    scene_of = {task.key: wanted[size][0] for task, size in zip(tasks, task_sizes)}
    return tasks, keys, {r.key: r for r in references.values()}, scene_of


def _on_executor(tasks, store, pool, payloads=None, **options) -> list:
    """Every task's outcome; a point sent back as files (a shipped task: ``payloads``, its
    reference and scene) is put in the store here, as it arrives, so that an interrupted
    run keeps what finished."""
    try:
        outcomes = []
        for outcome in run_tasks(run_point, tasks, pool=pool, payloads=payloads, **options):
            files = outcome.pop("files", None)
            if files is not None:
                try:
                    outcome["status"] = store.adopt_point(outcome["key"], files)
                except (OSError, ValueError) as exc:
                    if disk_full(exc):  # this disk, for every point: the run stops, naming the point (exit 2)
                        raise
                    outcome = {"key": outcome["key"], "error": f"its files could not be stored: {exc}"}
            outcomes.append(outcome)
        return outcomes
    except BaseException:  # Ctrl-C: the stopped workers' half-written points go now, not on the next run
        store.clean_stale()
        raise


def _read_back(store: Store, point: Point, key: str, images: tuple, measured: bool) -> PointResult | None:
    summary = store.summary(key)
    if summary is None:
        return None  # a failed point (reported in Measured.failed)
    folder = store.point_dir(key)
    try:
        tables = {t: pd.read_parquet(os.path.join(folder, f"{t}.parquet")) for t in TABLES}
    except Exception as exc:  # pyarrow raises its own types for a damaged file
        raise RunnerError(f"{folder}: the result of {point.scene} could not be read back ({exc})") from None
    read = {name: store.images(key, name) for name in images}
    return PointResult(point=point, key=key, summary=summary, tables=tables, views=read.get("views", {}),
                       layers=read.get("layers", {}), measured=measured)


# --- one point, in whichever process runs it ------------------------------------------

TOOLS: dict = {}


def run_point(task: PointTask, payload: dict | None = None, *, progress: bool = False,
              reference: ReferenceResult | None = None, scene: Scene | None = None) -> dict:
    """One point (picklable: plain data in and out). Tasks of one process run one at a
    time, whatever the executor's threads (GL and Mitsuba are per process). A local
    worker reads the run's reference from the cache by key and writes the point into the
    store; this process passes the reference (``reference``: as resolved, rendered in this
    run or cached) and the scene (``scene``: as the run resolved it). A shipped task
    (``payload``: its reference and its scene package, for a Dask worker, which may share
    no disk with the run) sends the point back as files (:func:`_shipped`)."""
    if task.version != TASK_VERSION:
        raise RuntimeError(f"a point task of version {task.version!r}; this worker's volcaustics runs version "
                           f"{TASK_VERSION}: install the same volcaustics on every worker")
    if payload is not None:
        return _shipped(task, payload, progress=progress)
    with PROCESS_LOCK:
        t0 = time.perf_counter()
        store = Store(task.store)
        if store.status(task.key, images=task.images) == "done":
            return {"key": task.key, "status": "done", "seconds": 0.0}
        scene = scene or point_scene(task.scene, task.fields)
        # the run's own, never rendered here: the very render the point's key names
        reference = reference or cached_reference(task.reference_key, scene,
                                                  task.key_document.get("reference_content"))
        if reference is None:
            raise RuntimeError(f"{task.scene}: reference {task.reference_key} is not in this worker's cache "
                               f"({cache_dir('reference')}) as the run resolved it: the workers need the run's cache "
                               f"(VOLCAUSTICS_CACHE on a shared file system), not continued meanwhile")
        experiment = _experiment(task, scene, reference, progress)
        status = store.write_point(task.key, task.key_document, experiment, images=task.images)
        return {"key": task.key, "status": status, "seconds": time.perf_counter() - t0}


def _experiment(task: PointTask, scene, reference, progress: bool):
    renderer, oracle = _tools(scene)
    request = ReferenceSettings(**task.key_document["reference_request"])  # the run's, which the summary judges by
    return run_experiment(scene, ApproxParams(**task.params), seeds=task.seeds, reference=reference,
                          reference_settings=request, renderer=renderer, oracle=oracle, progress=progress,
                          fields=dict(task.fields), measurement=MeasurementSettings(**task.measurement))


def _shipped(task: PointTask, payload: dict, *, progress: bool = False) -> dict:
    """A shipped point: measured with the reference it carries, written into a store of
    its own in a temporary folder, and returned as that point's files (the run puts them
    in its store: ``Store.adopt_point``). Nothing is read from or written to the run's
    disk, so the worker may be another machine."""
    import tempfile

    with PROCESS_LOCK:
        t0 = time.perf_counter()
        scene = unpacked(payload["scene_package"])  # its mesh files came with it
        experiment = _experiment(task, scene, payload["reference"], progress)
        with tempfile.TemporaryDirectory(prefix="volcaustics-point-") as folder:
            local = Store(folder)
            local.write_point(task.key, task.key_document, experiment, images=task.images)
            files = local.point_files(task.key)
        return {"key": task.key, "status": "measured", "seconds": time.perf_counter() - t0, "files": files}


def _tools(scene) -> tuple:
    """A renderer and an oracle per scene, kept for the process's life (shader
    compilation and the oracle's scene build are paid once per scene)."""
    key = scene.scene_hash()
    if key not in TOOLS:
        TOOLS[key] = (Renderer(scene), Oracle(scene))
    return TOOLS[key]
