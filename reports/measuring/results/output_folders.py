"""Output paths, checked before any work: an output file (and its siblings) or a folder
of outputs must be writable, hold no folder where a file goes, and hold no other command's
outputs. The commands (``reports.cli``) and the Python API (``reports.api``) check with
these, naming the option or argument."""

from __future__ import annotations

import os
from collections.abc import Iterable

from volcaustics.infra.errors import InputError


class OutputPathError(InputError):
    """An output path that cannot work; the message names the option (or argument), the
    value and the fix."""

    def __init__(self, option: str, value: object, fix: str):
        super().__init__(f"{option} = {value!r}: {fix}")


def check_output_file(path: str, option: str, extension: str, siblings: tuple = ()) -> None:
    """Fail before any work when the output file ``path`` (and the sibling outputs named
    after it, ``siblings``: suffixes replacing ``extension``) cannot be written: an empty
    name, a folder, a name without a stem or with another extension, a parent that cannot
    be (or become) a writable folder."""
    name = os.path.basename(path or "")
    if not path or path.endswith(("/", os.sep)) or name in (".", ".."):
        raise OutputPathError(option, path, f"expected a file name ending in {extension}")
    if not name.lower().endswith(extension) or len(name) == len(extension):
        raise OutputPathError(option, path, f"expected a file name ending in {extension}, e.g. out{extension}"
                                            + (" (the other outputs take its stem)" if siblings else ""))
    stem = path[: -len(extension)]
    check_no_folder_at([path, *(stem + suffix for suffix in siblings)], option, path)
    check_output_dir(os.path.dirname(os.path.abspath(path)), option)


def check_no_folder_at(files: Iterable[str], option: str, value: object) -> None:
    """Fail before any work when a folder is where one of the output ``files`` goes (the
    set's last rename would fail after the work, halfway through the set)."""
    for path in files:
        if os.path.isdir(path):
            raise OutputPathError(option, value, f"{path} is a folder where an output file goes: move it or "
                                                 f"choose another name")


# the file that marks a folder as one command's outputs, beside summary.json's "kind"
# (measure, compare, animate): frames, sweep and gate write no summary.json
FOLDER_MARKERS = {"frames.json": "frames", "sweep.json": "sweep", "gate.json": "gate"}


def check_output_set(folder: str, option: str, files: Iterable[str] = (), folders: Iterable[str] = (),
                     kind: str | None = None) -> None:
    """``folder`` must be (or become) a writable folder holding no folder where one of
    its output ``files`` goes and no file where one of its ``folders`` goes; with
    ``kind`` (the command's: its summary.json's "kind", or FOLDER_MARKERS'), no other
    command's outputs (they would be half replaced: a mixed folder)."""
    check_output_dir(folder, option)
    check_no_folder_at([os.path.join(folder, name) for name in files], option, folder)
    for name in folders:
        check_output_dir(os.path.join(folder, name), option)
    if kind is not None:
        for other, name in folder_kinds(folder).items():
            if other != kind:
                raise OutputPathError(option, folder, f"holds another command's outputs (its {name} is of kind "
                                                      f"{other!r}, this command writes {kind!r}): choose another "
                                                      f"folder")


def folder_kinds(folder: str) -> dict:
    """kind → the file that says so, for every command's outputs ``folder`` holds."""
    kinds = {}
    summary = _summary_kind(os.path.join(folder, "summary.json"))
    if summary is not None:
        kinds[summary] = "summary.json"
    for name, kind in FOLDER_MARKERS.items():
        if os.path.isfile(os.path.join(folder, name)):
            kinds.setdefault(kind, name)
    return kinds


def _summary_kind(path: str) -> str | None:
    """The "kind" of the summary.json at ``path``; None when there is none (or it cannot
    be read: the command replaces it)."""
    from volcaustics.infra.storage import read_json_object

    try:
        kind = read_json_object(path).get("kind") if os.path.isfile(path) else None
    except (OSError, ValueError):
        return None
    return kind if isinstance(kind, str) else None


def check_output_dir(path: str, option: str = "-o") -> None:
    """Fail before any work when ``path`` cannot be (or become) a writable folder."""
    if not path:
        raise OutputPathError(option, path, "expected an output folder")
    if os.path.exists(path) and not os.path.isdir(path):
        raise OutputPathError(option, path, "exists and is not a folder: choose a folder path")
    existing = os.path.abspath(path)
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing) or not os.access(existing, os.W_OK | os.X_OK):
        raise OutputPathError(option, path, f"cannot write there ({existing} is not a writable folder)")
