"""One writer per output folder: a command that fills a folder over minutes (a sweep, its
tables and figures) holds an OS lock on a file in it for the whole run, and a second
command into that folder is refused at once, naming the folder and the process holding it.

The lock is ``fcntl.flock`` on ``FOLDER/.volcaustics.lock``: the kernel holds it for the
open file, so it ends with the process however that process ends (SIGKILL, a power cut
on the next boot): a killed run never leaves a stale lock. The file stays (removing a
lock file races with the next run opening it) and says who holds it.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import socket
from collections.abc import Iterator

from .errors import InputError

LOCK_FILE = ".volcaustics.lock"
# a file system without flock (some network mounts): the run goes on unlocked, as before
_NO_LOCKS = (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EINVAL)


class FolderBusyError(InputError):
    """Another live process holds the output folder's lock; the message names the
    folder, that process and the fix."""


@contextlib.contextmanager
def folder_lock(folder: str, *, what: str, option: str = "-o") -> Iterator[None]:
    """Hold ``folder``'s lock (created with the folder when missing) for the block.

    Parameters
    ----------
    folder : the output folder.
    what : what this process is doing there, for the other's message ("sweep").
    option : the command-line option that names the folder, for the fix.

    Raises
    ------
    FolderBusyError : another live process holds it (an ``InputError``: exit 2).

    Example
    -------
    >>> with folder_lock("out/sweep", what="sweep"):  # doctest: +SKIP
    ...     write_the_folder()
    """
    import fcntl

    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, LOCK_FILE)
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusyError(f"{option} {folder}: {_holder(fd)} is writing this folder: wait for it to end, "
                                  f"or give another {option}") from None
        except OSError as exc:
            if exc.errno not in _NO_LOCKS:
                raise
        else:
            os.ftruncate(fd, 0)
            holder = {"pid": os.getpid(), "host": socket.gethostname(), "what": what}
            os.pwrite(fd, (json.dumps(holder) + "\n").encode(), 0)
        yield
    finally:
        os.close(fd)  # the lock goes with the file's last descriptor


def _holder(fd: int) -> str:
    """Who holds the lock, as its file says ("a sweep (process 1234 on host)"); "another
    process" when it does not say (written by a run just starting)."""
    try:
        doc = json.loads(os.pread(fd, 4096, 0).decode() or "null")
        return f"a {doc['what']} (process {int(doc['pid'])} on {doc['host']})"
    except (OSError, ValueError, TypeError, KeyError):
        return "another process"
