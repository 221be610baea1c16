"""``measure -o DIR``: an experiment's tables (Parquet and CSV), ``decomposition.exr`` and,
last, ``summary.json``, written as one set: from the point as the result store holds it
(``reports.measuring.runner.PointResult``) or from an :class:`~experiment.pipeline.Experiment`."""

from __future__ import annotations

import json
import os
import shutil
from typing import TYPE_CHECKING, Protocol

from volcaustics.infra.imageio import write_exr
from volcaustics.infra.storage import atomic_set
from volcaustics.reports.measuring.results.store import TABLES
from volcaustics.reports.measuring.results.tables import plain, table

if TYPE_CHECKING:
    from volcaustics.experiment.summaries import ExperimentSummary

    class _Written(Protocol):
        """What :func:`write_experiment` reads: a stored point
        (``reports.measuring.runner.PointResult``) or an ``Experiment``; the tables it
        reads by attribute."""

        @property
        def summary(self) -> ExperimentSummary: ...

        @property
        def layers(self) -> dict: ...

OUTPUT_FILES = (*(f"{name}.{ext}" for name in TABLES for ext in ("parquet", "csv")), "decomposition.exr",
                "summary.json")  # what `measure -o DIR` writes; the manifest, summary.json, last
DECOMPOSITION_IMAGES = {"approx": "A", "approx_exact_march": "A_m", "exact_steps": "E_k",
                        "exact_all_same": "E_inf(A's fresnel)", "exact_all": "E_inf", "exact_emission": "E_em",
                        "exact_all_small": "E_inf,s", "exact_all_small_eye": "E_inf,s,tau", "reference": "R"}


def output_paths(out_dir: str) -> dict:
    return {name: os.path.join(out_dir, name) for name in OUTPUT_FILES}


# what a stored summary holds for the store alone (its key's document, its files' hashes, its seal)
STORE_FIELDS = ("key_document", "files", "summary_sha256")


def write_experiment(experiment: _Written, out_dir: str, *, summary_file: str | None = None) -> dict:
    """Write the tables (Parquet + CSV), ``decomposition.exr`` and, last,
    ``summary.json`` into ``out_dir`` as one set (``infra.storage.atomic_set``: an
    interrupted write leaves the last complete set). ``experiment``: a stored point
    (``tables``: name → DataFrame, ``layers``, ``summary``), whose ``summary_file`` in the
    store is copied byte for byte (one summary per point, the same in the store and in
    ``out_dir``), or an ``Experiment`` (rows per table; its summary written without the
    store's fields). Returns the paths."""
    os.makedirs(out_dir, exist_ok=True)
    paths = output_paths(out_dir)  # summary.json last: the set's manifest
    s = {k: v for k, v in experiment.summary.items() if k not in STORE_FIELDS}
    stored = getattr(experiment, "tables", None)
    with atomic_set(list(paths.values())) as temps:
        tmp = dict(zip(paths, temps))
        for name in TABLES:
            frame = stored[name] if stored is not None else table(getattr(experiment, name))
            frame.to_parquet(tmp[f"{name}.parquet"], index=False)
            frame.to_csv(tmp[f"{name}.csv"], index=False)
        write_exr(tmp["decomposition.exr"], experiment.layers,
                  {"volcaustics_scene": s["scene"], "volcaustics_scene_hash": s["scene_hash"],
                   "volcaustics_renderer": "experiment",
                   "volcaustics_layers": json.dumps({**DECOMPOSITION_IMAGES, "term.*": "the decomposition's terms"}),
                   "volcaustics_params": json.dumps(s["params"], sort_keys=True)})
        if summary_file is not None:
            shutil.copyfile(summary_file, tmp["summary.json"])
        else:
            with open(tmp["summary.json"], "w", encoding="utf-8") as fh:
                fh.write(json.dumps(plain(s), indent=2, allow_nan=False))
    return paths
