"""A resumable result store of experiments (docs/architecture.md.

Layout of a store folder::

    points/<key>/segments.parquet, photons.parquet, images.parquet
    points/<key>/views.exr        optional: the images a report shows
                                  (``experiment.point_summary.VIEWS``; the report's store)
    points/<key>/layers.exr       optional: the error decomposition's images and terms
                                  (what ``measure -o DIR`` writes as decomposition.exr)
    points/<key>/summary.json     written last: the experiment's summary, the key's
                                  document, the SHA-256 of every file and of
                                  itself (``summary_sha256``)
    segments.parquet, photons.parquet, images.parquet, points.parquet
                                  all complete points in one table each
                                  (:meth:`Store.tables`), written by a sweep
                                  with its suffice.csv and, last, sweep.json
                                  as one set (``reports.studies.sweep.sweep_run``)

A point's key hashes everything that determines its result (:func:`point_key`): the
scene's hash, the resolved approximation parameters, the seeds, the reference's cache
key and the code version of what measures. One point is one folder, written under a
temporary name and renamed into place, so a point is there whole or not at all: an
interrupted sweep leaves at most a temporary folder (removed on the next run when its
process is gone), two sweeps writing one store never write one file (the second
rename finds the point there and drops its own copy), and a point whose files do not
match the hashes in its summary (a damaged file), or whose summary does not match its
own hash (an edited number), counts as missing and is recomputed.

Parquet (pyarrow) is the format: columnar, typed, compressed, read by pandas
(``pd.read_parquet(DIR/"images.parquet")``) and by DuckDB directly, also across the
per-point files (``SELECT * FROM 'DIR/points/*/images.parquet'``); one file per point
and table is what makes writing append-safe without a database server.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import uuid
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING, Protocol, cast

import pandas as pd

from volcaustics.experiment.result import Experiment
from volcaustics.experiment.summaries import ExperimentSummary, of_schema
from volcaustics.experiment.versions import code_version
from volcaustics.infra.imageio import read_exr, write_exr
from volcaustics.infra.storage import (
    atomic_write_text,
    document_sha256,
    file_sha256,
    orphaned,
    owner,
    read_json_object,
)
from volcaustics.reports.measuring.results.points_table import point_row
from volcaustics.reports.measuring.results.tables import plain, table

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reference.cache import ReferenceResult
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes.model import Scene

    class _Experiment(Protocol):
        """What :meth:`Store.write_point` reads of an experiment
        (``experiment.pipeline.Experiment``): its summary, and the
        tables and images it names by attribute."""

        @property
        def summary(self) -> ExperimentSummary: ...

TABLES = ("segments", "photons", "images")
TABLE_FILES = tuple(f"{name}.parquet" for name in TABLES)
VIEWS = "views.exr"
# the optional images of a point: the experiment's attribute → its file in the point's folder
IMAGE_FILES = {"views": VIEWS, "layers": "layers.exr"}
SUMMARY = "summary.json"
SEAL = "summary_sha256"  # a summary's field holding the SHA-256 of the rest of it (summary_sha256)
STORE_FORMAT = 1


def point_key(document: dict) -> str:
    """The key of a point: SHA-256 (32 hex digits) of its key document."""
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def key_document(scene: Scene, params: ApproxParams, seeds: int, reference: ReferenceResult,
                 request: ReferenceSettings) -> dict:
    """Everything that determines a point's result: the scene (its content, and its name,
    which its summary and tables carry: two files of one content and two names are two
    points), the resolved parameters,
    the seeds, the reference (``reference.render.ReferenceResult``: its cache key and,
    since an entry can be continued with more batches under one key, the hash of its
    content), the request it was served to (``request``, sized: its summary judges the
    entry against that request's target and caps, ``reference.served``) and the code version."""
    return {"format": STORE_FORMAT, "scene_hash": scene.scene_hash(), "scene": scene.name,
            "params": params.resolved(scene).to_dict(),
            "seeds": seeds, "reference_key": reference.key,
            "reference_content": reference.manifest.get("exr_sha256"), "reference_request": request.to_dict(),
            "code_version": code_version()}


def summary_sha256(summary: dict) -> str:
    """SHA-256 of a point's summary without its own hash (the field SEAL)
    (:func:`document_sha256`)."""
    return document_sha256(summary, SEAL)


def sealed(summary: dict) -> dict:
    """``summary`` with the SHA-256 of its content under SEAL (checked by :meth:`Store.summary`)."""
    return {**summary, SEAL: summary_sha256(summary)}


class Store:
    """The points of one store folder (created when missing)."""

    def __init__(self, root: str):
        self.root = root
        self.points = os.path.join(root, "points")
        os.makedirs(self.points, exist_ok=True)

    def point_dir(self, key: str) -> str:
        return os.path.join(self.points, key)

    def summary(self, key: str) -> ExperimentSummary | None:
        """The point's summary if the point is complete and undamaged (its summary of this
        key, matching its own SHA-256, its files matching theirs), else None. A summary
        edited by hand, or written before summaries carried their hash (an older
        store), counts as damaged: a sweep or the report recomputes the point."""
        return _complete_summary(self.point_dir(key), key)

    def experiment(self, key: str) -> Experiment | None:
        """The point's summary read into its typed :class:`Experiment` (the store's
        boundary: callers read attributes), None as :meth:`summary`."""
        summary = self.summary(key)
        return None if summary is None else Experiment.from_summary(summary, key=key)

    def stored_images(self, key: str) -> tuple | None:
        """The optional images (names of :data:`IMAGE_FILES`) a complete, undamaged point
        holds; None for a point missing or damaged (the point's files read once)."""
        summary = self.summary(key)
        return None if summary is None else tuple(n for n, f in IMAGE_FILES.items() if f in summary["files"])

    def status(self, key: str, *, images: tuple = ()) -> str:
        """"done" (complete and undamaged, with the files of ``images``: names of
        :data:`IMAGE_FILES`), "damaged" (a folder that is not) or "missing"."""
        held = self.stored_images(key)
        if held is not None and set(images) <= set(held):
            return "done"
        return "damaged" if os.path.isdir(self.point_dir(key)) else "missing"

    def images(self, key: str, name: str) -> dict:
        """The point's images ``name`` of :data:`IMAGE_FILES` (layer name → array): its
        views (``experiment.point_summary.VIEWS``) or its decomposition's layers."""
        layers, _ = read_exr(os.path.join(self.point_dir(key), IMAGE_FILES[name]))
        return layers

    def write_point(self, key: str, document: dict, experiment: _Experiment, *, images: tuple = ()) -> str:
        """Write a point whole, or not at all, with the experiment's images named in
        ``images`` (:data:`IMAGE_FILES`); returns "written", or "kept" when a complete
        copy appeared meanwhile (another sweep)."""
        tmp = os.path.join(self.points, f".tmp-{key}-{owner()}-{uuid.uuid4().hex[:8]}")
        with _naming_the_point(tmp, self.point_dir(key)):
            os.makedirs(tmp)
        try:
            with _naming_the_point(tmp, self.point_dir(key)):
                files = {}
                for name in TABLES:
                    path = os.path.join(tmp, f"{name}.parquet")
                    table(getattr(experiment, name)).to_parquet(path, index=False)
                    files[f"{name}.parquet"] = file_sha256(path)
                for name in images:
                    path = os.path.join(tmp, IMAGE_FILES[name])
                    write_exr(path, getattr(experiment, name), {"volcaustics_renderer": f"experiment {name}",
                                                                "volcaustics_scene": experiment.summary["scene"]})
                    files[IMAGE_FILES[name]] = file_sha256(path)
                summary = sealed({**plain(experiment.summary), "key": key, "key_document": document, "files": files})
                atomic_write_text(os.path.join(tmp, SUMMARY), json.dumps(summary, indent=1, allow_nan=False))
            return self._commit(tmp, key, images)
        finally:
            if os.path.isdir(tmp):
                shutil.rmtree(tmp, ignore_errors=True)

    def amend_summary(self, key: str, fields: dict) -> ExperimentSummary:
        """Add ``fields`` to a complete point's summary, resealed and written in one rename:
        what is measured of a point after it (its equal cost), kept with it from then on.
        Returns the summary as stored; OSError for a point missing or damaged, ValueError
        for a field the store owns."""
        summary = self.summary(key)
        if summary is None:
            raise OSError(f"point {key[:12]}: not complete in {self.root}: nothing to amend")
        owned = sorted(set(fields) & {"key", "key_document", "files", SEAL})
        if owned:
            raise ValueError(f"point {key[:12]}: {', '.join(owned)} belong to the store")
        doc = sealed({**{k: v for k, v in summary.items() if k != SEAL}, **plain(fields)})
        atomic_write_text(os.path.join(self.point_dir(key), SUMMARY), json.dumps(doc, indent=1, allow_nan=False))
        return cast(ExperimentSummary, doc)

    def point_files(self, key: str) -> dict:
        """The point's files as bytes (name → content): what a worker without the store's
        disk sends back for :meth:`adopt_point`."""
        folder = self.point_dir(key)
        out = {}
        for name in sorted(os.listdir(folder)):
            with open(os.path.join(folder, name), "rb") as fh:
                out[name] = fh.read()
        return out

    def adopt_point(self, key: str, files: dict) -> str:
        """Put a point another machine wrote (:meth:`point_files`) in place, whole or not at
        all; "written", or "kept" when a complete copy appeared meanwhile. A point whose
        files do not match its summary is refused (OSError), never stored."""
        tmp = os.path.join(self.points, f".tmp-{key}-{owner()}-{uuid.uuid4().hex[:8]}")
        with _naming_the_point(tmp, self.point_dir(key)):
            os.makedirs(tmp)
        try:
            for name, data in files.items():
                if os.path.basename(name) != name:
                    raise OSError(f"{name!r}: not a file name of a point")
                with _naming_the_point(tmp, self.point_dir(key)), open(os.path.join(tmp, name), "wb") as fh:
                    fh.write(data)
            if _complete_summary(tmp, key) is None:
                raise OSError(f"point {key[:12]}: the files sent back do not match its summary")
            return self._commit(tmp, key, tuple(n for n, f in IMAGE_FILES.items() if f in files))
        finally:
            if os.path.isdir(tmp):
                shutil.rmtree(tmp, ignore_errors=True)

    def _commit(self, tmp: str, key: str, images: tuple = ()) -> str:
        """Put ``tmp`` in place as point ``key``: "written", or "kept" when a complete copy
        with ``images`` is there already (one without them is replaced, as a damaged one)."""
        final = self.point_dir(key)
        for _ in range(3):
            try:
                os.rename(tmp, final)
                return "written"
            except OSError:
                if self.status(key, images=images) == "done":
                    return "kept"
                # a damaged, half-removed or image-less copy: move it aside, then retry
                aside = f"{final}.damaged-{uuid.uuid4().hex[:8]}"
                try:
                    os.rename(final, aside)
                    shutil.rmtree(aside, ignore_errors=True)
                except OSError:
                    pass
        raise OSError(f"{final}: cannot put the point in place")

    def remove_damaged(self, key: str, *, images: tuple = ()) -> None:
        """Set aside and remove the point's folder unless it is done (with ``images``)."""
        folder = self.point_dir(key)
        if os.path.isdir(folder) and self.status(key, images=images) != "done":
            aside = f"{folder}.damaged-{uuid.uuid4().hex[:8]}"
            try:
                os.rename(folder, aside)
            except OSError:
                return
            shutil.rmtree(aside, ignore_errors=True)

    def clean_stale(self) -> int:
        """Remove temporary folders of processes on this host that no longer run, and
        damaged copies set aside; returns how many were removed."""
        return remove_stale(self.points)

    def tables(self, keys: Iterable[str]) -> dict:
        """One DataFrame per kind over the complete points of ``keys`` (a ``point``
        column first), plus "points" (one row per point); written by the caller
        (``reports.studies.sweep.sweep_run`` writes them with its manifest as one set)."""
        frames: dict = {name: [] for name in TABLES}
        points = []
        for key in keys:
            summary = self.summary(key)
            if summary is None:
                continue
            for name in TABLES:
                frame = pd.read_parquet(os.path.join(self.point_dir(key), f"{name}.parquet"))
                frame.insert(0, "point", key)
                frames[name].append(frame)
            points.append(point_row(key, summary))
        out = {name: (pd.concat(parts, ignore_index=True) if parts else pd.DataFrame())
               for name, parts in frames.items()}
        out["points"] = table(points) if points else pd.DataFrame()
        return out


def remove_stale(folder: str) -> int:
    """Remove from ``folder`` the temporary folders of processes on this host that no
    longer run, and damaged copies set aside (a store's points, or its sealed sets);
    returns how many were removed."""
    removed = 0
    for name in os.listdir(folder):
        path = os.path.join(folder, name)
        stale = ".damaged-" in name
        if name.startswith(".tmp-"):  # .tmp-<key>-<host>-<pid>-<uuid> (scenes.storage.owner)
            parts = name.split("-")
            try:
                stale = len(parts) == 5 and orphaned(parts[2], int(parts[3]))
            except ValueError:
                continue
        if stale:
            shutil.rmtree(path, ignore_errors=True)
            removed += 1
    return removed


@contextlib.contextmanager
def _naming_the_point(tmp: str, final: str) -> Iterator[None]:
    """An OSError while a point is written into its temporary folder ``tmp`` names the
    point's folder ``final`` (or the file in it), never the hidden temporary: a full disk
    in pyarrow's writer names no file at all, and says "Error writing bytes to file"."""
    try:
        yield
    except OSError as exc:
        if exc.errno is None:  # one of ours, worded already
            raise
        name = os.fspath(exc.filename) if exc.filename else ""
        where = final + name[len(tmp):] if name.startswith(tmp) else (name or final)
        raise OSError(exc.errno, os.strerror(exc.errno), where) from exc


def _complete_summary(folder: str, key: str) -> ExperimentSummary | None:
    """The summary in ``folder`` if it is of ``key`` and of this code's experiment schema
    (``summaries.SCHEMAS``), matches its own SHA-256 and its files match theirs (every
    table, and the image files it lists), else None."""
    try:
        summary = read_json_object(os.path.join(folder, SUMMARY))
        if summary.get("key") != key or summary.get(SEAL) != summary_sha256(summary) \
                or not of_schema(summary, "experiment"):
            return None
        hashes = summary.get("files")
        if not isinstance(hashes, dict) or not set(hashes) <= {*TABLE_FILES, *IMAGE_FILES.values()} \
                or not set(TABLE_FILES) <= set(hashes):
            return None
        for name, digest in hashes.items():
            if file_sha256(os.path.join(folder, name)) != digest:
                return None
        return cast(ExperimentSummary, summary)
    except (OSError, ValueError):
        return None
