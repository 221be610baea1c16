"""A sweep store read back for the report: sweep.json checked against the hashes it
records, the consolidated tables, and notes where the store differs from this code."""

from __future__ import annotations

import os

import pandas as pd

from volcaustics.approx.params import PARAMS, ApproxParams
from volcaustics.experiment.versions import code_version
from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import file_sha256, read_json_object, special_file_kind
from volcaustics.reports.measuring.results.points_table import POINT_COLUMNS
from volcaustics.reports.measuring.results.store import document_sha256
from volcaustics.reports.measuring.results.sweep_tables import SweepTables
from volcaustics.reports.studies.sweep.sweep_run import MANIFEST_SEAL


class ReportError(InputError):
    """Bad report input (a scene, a sweep store, an output folder): exit 2; the
    message names the value and the fix."""


def load_sweep(folder: str) -> SweepTables:
    """A sweep store's consolidated tables (``volcaustics sweep -o DIR`` wrote them)."""
    try:
        doc = read_json_object(os.path.join(folder, "sweep.json"))
    except FileNotFoundError:
        raise ReportError(f"--sweep {folder}: no sweep.json: not a sweep store (run `volcaustics sweep ... -o "
                          f"{folder}` first)") from None
    except ValueError as exc:
        raise ReportError(f"--sweep: {exc}: rerun the sweep") from None
    spec = doc.get("spec")
    if not isinstance(spec, dict) or not isinstance(spec.get("vary"), dict):
        raise ReportError(f"--sweep {folder}: sweep.json has no spec with a \"vary\" table: rerun the sweep")
    names: tuple[str, ...] = ("segments", "photons", "images", "points")
    if isinstance(doc.get("files"), dict) and "best.parquet" in doc["files"]:
        names += ("best",)  # the best-configuration search's table (reports.studies.best.best_search)
    hashes = _check_hashes(folder, doc, names)
    tables = {name: _sweep_table(folder, name) for name in names}
    if len(tables["points"]) == 0:
        raise ReportError(f"--sweep {folder}: the sweep holds no finished point")
    notes = hashes + _check_schema(folder, tables["points"])
    return SweepTables(folder=folder, tables=tables, varied=list(spec["vary"]), spec=spec, notes=notes)


def _check_hashes(folder: str, doc: dict, names) -> list:
    """Check sweep.json against the SHA-256 it records of itself, and the tables
    ``names`` against those it records (``files``): ReportError naming a file edited or
    damaged since the sweep wrote it. A store from
    before sweep.json recorded them is drawn unchecked: returns the note the page shows."""
    if MANIFEST_SEAL in doc and doc[MANIFEST_SEAL] != document_sha256(doc, MANIFEST_SEAL):
        raise ReportError(f"--sweep {folder}: sweep.json does not match the SHA-256 it records of itself (edited "
                          f"or damaged since the sweep wrote it): rerun the sweep (`volcaustics sweep SPEC -o "
                          f"{folder}` keeps every undamaged point)")
    files = doc.get("files")
    if not isinstance(files, dict):
        return ["its sweep.json records no SHA-256 of its tables (written by an older volcaustics), so they are "
                "shown unchecked: rerun the sweep to record them"]
    for name in names:
        path = os.path.join(folder, f"{name}.parquet")
        try:
            digest = file_sha256(path)
        except FileNotFoundError:
            continue  # _sweep_table says what is missing
        except OSError as exc:
            raise ReportError(f"--sweep {folder}: {name}.parquet unreadable ({exc}): rerun the sweep") from None
        if files.get(f"{name}.parquet") != digest:
            raise ReportError(f"--sweep {folder}: {name}.parquet does not match the SHA-256 its sweep.json records "
                              f"(edited or damaged since the sweep wrote it): rerun the sweep (`volcaustics sweep "
                              f"SPEC -o {folder}` keeps every undamaged point)")
    return []


def _check_schema(folder: str, points: pd.DataFrame) -> list:
    """Check a store's points table against this code's (``points_table.POINT_COLUMNS`` and the
    parameter table); returns the notes the page shows. A column of numbers missing: an
    older store, refused (ReportError naming them). A parameter missing: the store
    predates it, so its points ran the parameter's default, which is filled in and noted.
    Points of another code version: noted (their numbers may differ from this code's)."""
    versions = sorted({str(v) for v in points["code_version"]}) if "code_version" in points else ["unknown"]
    missing = [c for c in POINT_COLUMNS if c not in points]
    if missing:
        raise ReportError(f"--sweep {folder}: its points table lacks {', '.join(missing)}: written by an older "
                          f"volcaustics (code version {', '.join(versions)}); rerun the sweep with this code "
                          f"(`volcaustics sweep SPEC -o {folder}` keeps nothing it cannot use)")
    notes = []
    defaults = ApproxParams()
    absent = [p.name for p in PARAMS if p.name not in points]
    for name in absent:
        points[name] = getattr(defaults, name)
    if absent:
        notes.append(f"the store predates the parameter{'s' if len(absent) > 1 else ''} {', '.join(absent)}: its "
                     f"points ran the default ({', '.join(f'{n} = {getattr(defaults, n)}' for n in absent)})")
    current = code_version()
    if versions != [current]:
        notes.append(f"measured by code version {', '.join(versions)}, not this code's {current}: its numbers may "
                     f"differ from what this code measures; rerun the sweep to refresh them")
    return notes


def _sweep_table(folder: str, name: str) -> pd.DataFrame:
    path = os.path.join(folder, f"{name}.parquet")
    special = special_file_kind(path)
    if special:  # never opened: a FIFO would block
        raise ReportError(f"--sweep {folder}: {name}.parquet is {special}: rerun the sweep")
    try:
        return pd.read_parquet(path)
    except FileNotFoundError:
        raise ReportError(f"--sweep {folder}: no {name}.parquet: the sweep has not finished a point "
                          f"(rerun it to consolidate)") from None
    except Exception as exc:  # pyarrow raises its own types for a damaged file
        raise ReportError(f"--sweep {folder}: {name}.parquet unreadable ({exc}): rerun the sweep") from None


