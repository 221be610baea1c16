"""Where cached data lives and how files are written without ever leaving a
half-written file behind (temporary file in the same folder, then rename).

Shared by every package (``scenes`` sits at the bottom of the data flow).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import socket
import tempfile
from collections.abc import Iterator

from .interrupts import interrupts_held


class CacheError(OSError):
    """The cache folder cannot be used (it is a file, or not writable); the message
    names it and the fix."""


def cache_dir(*parts: str) -> str:
    """``$VOLCAUSTICS_CACHE``, else ``$XDG_CACHE_HOME/volcaustics``, else
    ``~/.cache/volcaustics``; joined with ``parts``, created, and checked to be a
    writable folder (:class:`CacheError` if not)."""
    variable = "VOLCAUSTICS_CACHE" if os.environ.get("VOLCAUSTICS_CACHE") else None
    path = cache_path(*parts)
    fix = f"point {variable or 'VOLCAUSTICS_CACHE'} at a writable folder"
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        raise CacheError(f"cache folder {path} cannot be created ({exc.strerror or exc}): {fix}") from None
    if not os.path.isdir(path) or not os.access(path, os.W_OK | os.X_OK):
        raise CacheError(f"cache folder {path} is not a writable folder: {fix}")
    return path


def cache_path(*parts: str) -> str:
    """The cache folder (as :func:`cache_dir` finds it) joined with ``parts``, neither
    created nor checked: where a cached file is read. A read-only cache serves what it
    holds; :func:`cache_dir` checks the folder only when something must be written."""
    root = os.environ.get("VOLCAUSTICS_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "volcaustics")
    return os.path.join(root, *parts)


_NOTED: set = set()


def note_not_cached(exc: OSError, what: str) -> None:
    """Say once per process, on stderr, that ``what`` is not cached because the cache
    cannot be written (``exc``: a CacheError names the folder and the fix; another
    OSError the file): the run goes on (nothing it needs is missing), but would
    otherwise redo that work every time without a word."""
    import sys

    if str(exc) not in _NOTED:
        _NOTED.add(str(exc))
        print(f"volcaustics: note: {exc}; {what} are computed again each run, not cached", file=sys.stderr)


@contextlib.contextmanager
def atomic_path(path: str) -> Iterator[str]:
    """Yield a temporary path next to ``path``; on success rename it onto ``path``.

    On an exception the temporary file is removed and ``path`` is untouched. The
    temporary name keeps the extension, so writers that look at it still work.
    """
    _not_a_folder(path)
    with interrupts_held():  # the temporary made is known to the cleanup below
        tmp = _temporary_beside(path)
    try:
        with _errors_naming([tmp], [path]):
            yield tmp
        _usual_mode(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


@contextlib.contextmanager
def _errors_naming(temps: list, paths: list):
    """An OSError raised while ``temps`` are written names the output it was for (the
    path in ``paths`` whose temporary it was, or whose temporary's own temporary), not a
    hidden name; one that names no file (a full disk in a library's writer) names the
    first output. OpenEXR reports a failed write as a RuntimeError: an OSError too."""
    import errno

    try:
        yield
    except OSError as exc:
        # a full disk or quota is the output's, whichever file the writer named (a copy names its source)
        full = exc.errno in (errno.ENOSPC, errno.EDQUOT)
        raise OSError(exc.errno, exc.strerror or str(exc),
                      _output_of(None if full else exc.filename, temps, paths)) from exc
    except RuntimeError as exc:
        if "write" not in str(exc).lower():
            raise
        code = errno.ENOSPC if "No space" in str(exc) else errno.EIO
        raise OSError(code, os.strerror(code), _output_of(None, temps, paths)) from exc


def _output_of(filename, temps: list, paths: list) -> str:
    """The output in ``paths`` that ``filename`` was written for (see :func:`_errors_naming`)."""
    if filename:
        name = os.path.basename(str(filename))
        for tmp, path in zip(temps, paths):
            stem = os.path.splitext(os.path.basename(tmp))[0]
            if name == os.path.basename(tmp) or name.startswith(("." + stem)[:121]):  # its own temporary's
                return path
        return str(filename)
    return paths[0]


def _not_a_folder(path: str) -> None:
    """IsADirectoryError naming ``path`` when a folder is where that file goes (checked
    before anything is written: a rename onto it would fail halfway through a set)."""
    import errno

    if os.path.isdir(path):
        raise IsADirectoryError(errno.EISDIR, "a folder is where this output file goes: move it away", path)


def _temporary_beside(path: str) -> str:
    """A new empty hidden file in ``path``'s folder (created if missing), named after it,
    this host and process (:func:`remove_stale_temporaries`), and keeping its extension,
    so writers that look at the extension still work."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    remove_stale_temporaries(folder)
    base, ext = os.path.splitext(os.path.basename(path))
    # a name near the file system's limit (255) must leave room for what marks the temporary
    fd, tmp = tempfile.mkstemp(prefix=f".{base[:120]}.{owner()}-", suffix=f".tmp{ext[:16]}", dir=folder)
    os.close(fd)
    return tmp


# mkstemp's random part: 8 of [a-z0-9_]
_TEMPORARY = re.compile(r"^\..*\.(?P<host>[^./]+)-(?P<pid>\d+)-[a-z0-9_]{8}\.tmp(\.[^/]*)?$")


def owner() -> str:
    """``host-pid`` of this process, as temporaries carry it (``.`` and ``-`` in the host
    name become ``_``): :func:`orphaned` tells whether its process is gone."""
    return f"{socket.gethostname().replace('.', '_').replace('-', '_')}-{os.getpid()}"


def remove_stale_temporaries(folder: str) -> int:
    """Remove the temporaries in ``folder`` that a process of this host left when it was
    killed (SIGKILL, a power cut: no ``finally`` ran) and that no running process owns;
    returns how many went. Called before every temporary is made in a folder, so each
    output folder and the cache clean up after the next run that writes there."""
    removed = 0
    try:
        names = os.listdir(folder)
    except OSError:
        return 0
    for name in names:
        match = _TEMPORARY.match(name)
        if match and orphaned(match["host"], int(match["pid"])):
            try:
                os.unlink(os.path.join(folder, name))
                removed += 1
            except OSError:
                pass
    return removed


def orphaned(host: str, pid: int) -> bool:
    """Whether a file marked by :func:`owner` as ``host-pid``'s was left by a process of
    this host that no longer runs (a file of another host is never judged)."""
    return host == owner().rsplit("-", 1)[0] and not process_alive(pid)


def process_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this host (one of another user counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _usual_mode(path: str) -> None:
    """mkstemp creates 0600; give the usual file mode (0666 less the umask)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


@contextlib.contextmanager
def atomic_set(paths: list) -> Iterator[list[str]]:
    """Write several files as one unit: yields temporary paths (in ``paths``' order) to
    write; when the block succeeds they replace ``paths`` together, with interrupts
    (SIGINT, SIGTERM: ``infra.interrupts.interrupts_held``) held back: the last path
    (the set's manifest) is removed first and put in place last, so no reader finds a
    manifest beside data of another run. When the block fails (an
    error, Ctrl-C) the temporaries go and every old file stays as it was."""
    for path in paths:
        _not_a_folder(path)
    temps: list[str] = []
    try:
        with interrupts_held():  # each temporary made is known to the cleanup below
            for path in paths:
                temps.append(_temporary_beside(path))
        with _errors_naming(temps, paths):
            yield list(temps)
        with interrupts_held():
            for tmp in temps:
                _usual_mode(tmp)
            remove_file(paths[-1])
            for tmp, path in zip(temps, paths):
                os.replace(tmp, path)
    finally:
        for tmp in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)


def atomic_write_texts(texts: dict) -> None:
    """Write text files (path → text; the last one the set's manifest) as one unit
    (:func:`atomic_set`)."""
    with atomic_set(list(texts)) as temps:
        for tmp, text in zip(temps, texts.values()):
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(text)


def remove_file(path: str) -> None:
    """Remove the file ``path`` if it is there (an earlier run's manifest or verdict that
    must not outlive its data or stand for a run that stopped early)."""
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def atomic_write_bytes(path: str, data: bytes) -> None:
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)


def atomic_write_text(path: str, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def document_sha256(doc: dict, field: str) -> str:
    """SHA-256 of a JSON document without its field ``field`` (where it keeps this
    digest, sealing it: a number edited by hand no longer matches): of its canonical
    JSON (sorted keys, no spaces), so reading it back and hashing again gives the same
    digest."""
    import json

    content = {k: v for k, v in doc.items() if k != field}
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def file_sha256(path: str) -> str:
    """SHA-256 (hex) of a file's bytes, read in 1 MiB chunks; OSError for a folder or a
    special file (a FIFO would block, a device never end)."""
    special = special_file_kind(path)
    if special:
        raise OSError(f"{path}: {special}, expected a file")
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def read_json_object(path: str) -> dict:
    """The JSON object stored in ``path``.

    FileNotFoundError when there is no file; ValueError naming the path when it is a
    folder or a special file (never opened), cannot be read, is not UTF-8 JSON, or holds
    something other than an object (``null``, a list): a manifest of that kind is damaged,
    never data to index into."""
    import json

    special = special_file_kind(path)
    if special:  # opening a FIFO blocks, a device never ends
        raise ValueError(f"{path}: {special}, expected a JSON file")
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except FileNotFoundError:
        raise
    except (OSError, ValueError) as exc:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise ValueError(f"{path}: unreadable ({exc})") from None
    if not isinstance(doc, dict):
        raise ValueError(f"{path}: expected a JSON object, found {type(doc).__name__}")
    return doc


def special_file_kind(path: str) -> str | None:
    """What ``path`` is when it exists and is not a regular file ("a folder", or "not a
    regular file (a device, FIFO or socket)"), else None. Check before reading: a device
    such as /dev/zero never ends and opening a FIFO blocks. A missing file gives None
    (whoever opens it reports that)."""
    import stat

    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    return "a folder" if stat.S_ISDIR(mode) else "not a regular file (a device, FIFO or socket)"
