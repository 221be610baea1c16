"""``volcaustics sweep``: every point of a grid (``sweep.spec``) measured through the
runner (``reports.measuring.runner``) into a resumable store on local processes or Dask, then
the store's consolidated tables, the settings that suffice and the figures."""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field

import pandas as pd

from volcaustics.experiment.measurement import measurement_settings
from volcaustics.experiment.sizing import reference_settings
from volcaustics.infra.folder_lock import folder_lock
from volcaustics.infra.storage import atomic_set, file_sha256, remove_file
from volcaustics.reports.measuring import runner
from volcaustics.reports.measuring.results.store import TABLES, Store, document_sha256
from volcaustics.reports.presenting.figures.plotting import remove_stale_figures
from volcaustics.reports.studies.sweep.best_figures import draw_best
from volcaustics.reports.studies.sweep.density_reading import crossings, has_depth_sweep
from volcaustics.reports.studies.sweep.suffice import settings_that_suffice
from volcaustics.reports.studies.sweep.sweep_figures import draw_figures
from volcaustics.reports.studies.sweep.sweep_spec import SweepSpec, points
from volcaustics.reports.studies.sweep.variants import best_variants, draw_variants, is_variants_sweep, variant_table

MANIFEST = "sweep.json"  # the spec, the points the store's tables hold, their SHA-256s; written last
MANIFEST_SEAL = "sweep_sha256"  # sweep.json's field holding the SHA-256 of the rest of it
OUTPUT_FILES = (*(f"{name}.parquet" for name in (*TABLES, "points")), "suffice.csv", MANIFEST)
OUTPUT_FOLDERS = ("points", "figures")
VARIANT_FILES = ("variants.csv", "variants_best.csv")  # beside them when the sweep varies search or start_rule
EXTRA_FILES = ("best.parquet",)  # beside them after the best-configuration search (reports.studies.best.best_search)
# beside them when the sweep varies the optical depth (reports.studies.sweep.density_reading)
DEPTH_FILES = ("model_crossing.csv",)


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
    """Run every point not yet in the store at ``out_dir`` (references: the cached one
    as it is, a missing one rendered, so a resumed sweep measures against the reference
    its first points had); then consolidate the tables and draw the figures. Ctrl-C
    stops it with the finished points kept. The folder is this sweep's for the whole run
    (``infra.folder_lock``): a sweep into a folder another live sweep holds is refused
    (FolderBusyError, exit 2), before anything renders."""
    t0 = time.perf_counter()
    with folder_lock(out_dir, what="sweep"):
        store = Store(out_dir)
        run = runner.measure(points(spec), store, reference_settings=reference_settings(spec.reference),
                             measurement=measurement_settings(spec.measurement),
                             policy="missing", workers=workers, dask=dask, progress=progress, read_back=False)
        keys = sorted(set(run.keys))
        tables, figures = consolidate(store, out_dir, spec, keys)
    return SweepResult(total=len(keys), done_before=run.done_before, computed=run.computed, failed=run.failed,
                       seconds=time.perf_counter() - t0, tables=tables, figures=figures,
                       point_seconds=run.point_seconds)


def consolidate(store: Store, out_dir: str, spec: SweepSpec, keys: list, *, extra: dict | None = None,
                manifest: dict | None = None) -> tuple:
    """The store's consolidated tables of ``keys`` (with the variant tables when the
    sweep varies a variant choice, and ``extra``: name → DataFrame, written as
    NAME.parquet), written with sweep.json (``manifest`` added to it) as one set; then
    the figures. Returns (tables, figure paths)."""
    varied = [name for name, _ in spec.vary]
    tables = store.tables(keys)
    # no point finished: an empty table, never an earlier run's
    tables["suffice"] = settings_that_suffice(tables["points"], varied) if len(tables["points"]) else pd.DataFrame()
    # the best search's points differ in photon_res and more than the variant: not a variants view
    variants = is_variants_sweep(varied) and len(tables["points"]) > 0 and "best" not in (extra or {})
    if variants:
        tables["variants"] = variant_table(tables)
        tables["variants_best"] = best_variants(tables["variants"])
    depth = has_depth_sweep(tables["points"])
    if depth:
        tables["model_crossing"] = crossings(tables["points"])
    tables.update(extra or {})
    # the earlier run's figures and variant tables go first: interrupted after the new
    # tables, the folder holds no figure of another run (the report redraws its own)
    remove_stale_figures(os.path.join(out_dir, "figures"), keep=[])
    for name in (*([] if variants else VARIANT_FILES), *([] if extra else EXTRA_FILES),
                 *([] if depth else DEPTH_FILES)):
        remove_file(os.path.join(out_dir, name))
    _write_tables(out_dir, tables, {"spec": spec.to_dict(), "points": len(keys), "keys": keys, **(manifest or {})},
                  extra=(*(VARIANT_FILES if variants else ()), *(DEPTH_FILES if depth else ()),
                         *(f"{name}.parquet" for name in extra or {})))
    figures = draw_figures(tables, os.path.join(out_dir, "figures"), varied=varied)
    if variants:
        figures += draw_variants(tables["variants"], os.path.join(out_dir, "figures"))
    if "best" in tables:
        figures += draw_best(tables["best"], os.path.join(out_dir, "figures"))
    return tables, figures


def _write_tables(out_dir: str, tables: dict, manifest: dict, extra: tuple = ()) -> None:
    """The consolidated tables, suffice.csv and, last, sweep.json as one set
    (``infra.storage.atomic_set``): an interrupted sweep leaves the last complete set,
    never a manifest beside another run's tables (what ``report --sweep`` reads). The
    manifest records each file's SHA-256 (``files``) and its own (MANIFEST_SEAL), which
    the report checks."""
    names = [name for name in OUTPUT_FILES if name != MANIFEST] + list(extra)
    with atomic_set([os.path.join(out_dir, name) for name in (*names, MANIFEST)]) as temps:
        files = {}
        for name, tmp in zip(names, temps):
            if name.endswith(".csv"):
                tables[name[: -len(".csv")]].to_csv(tmp, index=False)
            else:
                tables[name[: -len(".parquet")]].to_parquet(tmp, index=False)
            files[name] = file_sha256(tmp)
        doc = {**manifest, "files": files}
        doc[MANIFEST_SEAL] = document_sha256(doc, MANIFEST_SEAL)
        with open(temps[-1], "w", encoding="utf-8") as fh:
            fh.write(json.dumps(doc, indent=1))
