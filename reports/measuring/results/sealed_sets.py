"""A study's output stored whole in the result store: a sealed set of files.

A set is one folder, ``<store>/<kind folder>/<key>/``: the study's files and, last, its
``summary.json``, which names its ``key``, the SHA-256 of every other file (``files``) and
its own (``summary_sha256``, as a point's: ``store.sealed``). It is written under a
temporary name and renamed into place, so it is there whole or not at all (a temporary
folder whose process is gone is removed by the next writer); a set whose
files or summary do not match their hashes counts as missing and is measured again. A
command's ``-o DIR`` receives a byte-for-byte copy (:func:`copy_set`): one summary per
result, the same in the store and in ``DIR``. ``animate`` stores its animations so.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import uuid
from collections.abc import Callable

from volcaustics.infra.storage import atomic_set, atomic_write_text, file_sha256, owner, read_json_object
from volcaustics.reports.measuring.results.store import SEAL, SUMMARY, remove_stale, sealed, summary_sha256

STORE_FIELDS = ("key", "files", SEAL)  # what a stored set's summary holds for the store alone


def complete_set(folder: str, key: str, kind: str) -> dict | None:
    """The summary in ``folder`` if it is a sealed set of ``key`` and ``kind`` that
    :func:`damaged_set` finds whole, else None (missing, damaged or edited)."""
    try:
        summary = read_json_object(os.path.join(folder, SUMMARY))
        files = summary.get("files")
        if summary.get("key") != key or summary.get("kind") != kind or not isinstance(files, dict) or not files:
            return None
        return summary if damaged_set(folder, summary) is None else None
    except (OSError, ValueError):
        return None


def damaged_set(folder: str, summary: dict) -> str | None:
    """Why the sealed set in ``folder`` (its ``summary``, as read) is damaged: its summary
    edited or a file changed; None when it is whole or was never sealed (an output
    written before sets were stored)."""
    if SEAL not in summary:  # a set's summary always has it: one without it lost it
        return "its summary.json lost its seal" if "files" in summary or "key" in summary else None
    if summary.get(SEAL) != summary_sha256(summary):
        return "its summary.json was edited after it was written"
    for name, digest in (summary.get("files") or {}).items():
        path = os.path.join(folder, name)
        if os.path.basename(name) != name or not os.path.isfile(path) or file_sha256(path) != digest:
            return f"{name} is not the file it was written as"
    return None


def write_set(folder: str, key: str, kind: str, write: Callable[[str], dict]) -> dict:
    """Measure a set into a temporary folder beside ``folder`` and put it in place whole.

    ``write(tmp)`` writes the study's files into ``tmp`` and returns its summary (``kind``
    and the study's fields, without :data:`STORE_FIELDS`). A complete set that appeared
    meanwhile (another process) is kept and its summary returned; else the new one's."""
    parent = os.path.dirname(folder)
    os.makedirs(parent, exist_ok=True)
    remove_stale(parent)  # an earlier writer's temporary folder, its process gone
    tmp = os.path.join(parent, f".tmp-{key}-{owner()}-{uuid.uuid4().hex[:8]}")
    os.makedirs(tmp)
    aside: list[str] = []
    try:
        summary = write(tmp)
        files = {name: file_sha256(os.path.join(tmp, name)) for name in sorted(os.listdir(tmp)) if name != SUMMARY}
        doc = sealed({**summary, "kind": kind, "key": key, "files": files})
        atomic_write_text(os.path.join(tmp, SUMMARY), json.dumps(doc, indent=2, allow_nan=False))
        for _ in range(3):
            try:
                os.rename(tmp, folder)
                return doc
            except OSError:
                kept = complete_set(folder, key, kind)  # another process's, complete: kept
                if kept is not None:
                    return kept
                aside.append(f"{folder}.damaged-{uuid.uuid4().hex[:8]}")
                with contextlib.suppress(OSError):  # gone meanwhile, or set aside by another process
                    os.rename(folder, aside[-1])
        raise OSError(f"{folder}: cannot put the measured set in place (another process keeps replacing it)")
    finally:
        for path in (tmp, *aside):  # the new set is in place before a damaged one is deleted
            if os.path.isdir(path):
                shutil.rmtree(path, ignore_errors=True)


def copy_set(folder: str, summary: dict, out_dir: str) -> dict:
    """Copy a complete set's files and, last, its ``summary.json`` into ``out_dir`` as one
    unit (``infra.storage.atomic_set``), byte for byte; returns name → path written."""
    os.makedirs(out_dir, exist_ok=True)
    names = [*summary["files"], SUMMARY]
    paths = {name: os.path.join(out_dir, name) for name in names}
    with atomic_set(list(paths.values())) as temps:
        for name, tmp in zip(names, temps):
            shutil.copyfile(os.path.join(folder, name), tmp)
    return paths
