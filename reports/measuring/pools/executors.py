"""Where a run's reference batches and points run: local worker processes (default)
or Dask distributed, one pool for both (:func:`open_pool`: a worker starts once).

GL contexts and Mitsuba variants belong to a process, so every executor runs one
task per worker process at a time: a local pool of ``spawn``ed processes (a fork
would inherit the parent's Dr.Jit and GL state), or Dask workers with one thread
each (``--dask local:N`` starts a ``LocalCluster`` of N such processes; for
``--dask tcp://HOST:PORT`` start the workers with ``--nthreads 1``, and
``reference.render.tasks.PROCESS_LOCK`` also serialises the tasks of one process).
A local worker renders with Dr.Jit on its share of the cores (one thread each when
there are as many workers as cores: the light tracer's splats then add in one order,
docs/decisions.md "Reference batches on workers"). Results come back as they finish;
Ctrl-C cancels what has not started, stops the workers and re-raises
KeyboardInterrupt (finished points are already in the store).
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Callable, Iterator
from typing import Any, Protocol

from volcaustics.reports.measuring.pools.dask_address import ExecutorError, parse_dask

# a scatter that has not finished in this time is tried again; generous for a reference's
# arrays on a slow link
SCATTER_SECONDS = 120


class Pool(Protocol):
    """What :func:`open_pool` yields (local worker processes or a Dask client, started
    when first used), as :func:`run_tasks` and ``reference.render.sources.Pooled`` use it."""

    @property
    def workers(self) -> int: ...

    def submit(self, fn: Callable[..., Any], *args: Any, key: str | None = None) -> Any: ...

    def scattered(self, payload: dict) -> dict: ...

    def task_key(self, key: str) -> str | None: ...

    def as_completed(self, futures: list) -> Iterator[Any]: ...

    def cancel(self, futures: list) -> None: ...

    def abort(self) -> None: ...

    def close(self) -> None: ...


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def run_tasks(fn: Callable[..., dict], tasks: list, *, pool: Pool, total: int, done: int = 0, progress: bool = True,
              desc: str = "sweep", payloads: list | None = None) -> Iterator[dict]:
    """Yield ``fn(task)``'s results (dicts; a failed task gives {"key", "error"}) from
    ``pool`` (:func:`open_pool`) as they finish, with one progress bar (``desc``) of
    points done / ``total`` (``done`` already). Each task has a ``key``. ``payloads``: per
    task, what it ships beside it (name → (identity, value)): ``fn(task, payload)`` gets
    name → value, each value sent to a cluster once per identity (:meth:`_DaskPool.scattered`)."""
    from tqdm import tqdm

    bar = tqdm(total=total, initial=done, desc=desc, unit="point", disable=not progress, smoothing=0.1)
    try:
        if not tasks:  # nothing to send: the pool is not started for it
            return
        if payloads is None:
            futures = {pool.submit(fn, task, key=pool.task_key(task.key)): task.key for task in tasks}
        else:
            sent = [pool.scattered(payload) for payload in payloads]  # all data out first, then the tasks
            futures = {pool.submit(fn, task, payload, key=pool.task_key(task.key)): task.key
                       for task, payload in zip(tasks, sent)}
        for future in pool.as_completed(list(futures)):
            try:
                result = future.result()
            except Exception as exc:  # a point that fails is reported; the others go on
                if disk_full(exc):  # ...but a full disk is every point's: the run stops, naming the file (exit 2)
                    raise
                result = {"key": futures[future], "error": describe_failure(exc)}
            bar.update()
            if result.get("error"):
                bar.write(f"{desc}: point {result['key'][:12]} failed: {result['error']}")
            yield result
    finally:
        bar.close()


@contextlib.contextmanager
def open_pool(*, workers: int | None = None, dask: str | None = None) -> Iterator[Pool]:
    """A pool of worker processes for a run's reference batches and points: ``dask``
    (``parse_dask``) or ``workers`` local processes (default: one per core). On an
    exception or Ctrl-C what has not started is cancelled and local workers are killed,
    then it is re-raised (finished points are already in the store)."""
    pool = _Lazy(lambda: _DaskPool(dask) if dask else _LocalPool(workers or default_workers()))
    try:
        yield pool
    except BaseException:
        pool.abort()
        raise
    finally:
        pool.close()


class _Lazy:
    """A pool started when it is first used: a run that renders and measures nothing
    (everything cached and stored) starts no cluster and connects to no scheduler."""

    def __init__(self, start):
        self._start, self._pool = start, None

    def __getattr__(self, name):
        if self._pool is None:
            self._pool = self._start()
        return getattr(self._pool, name)

    def abort(self) -> None:
        if self._pool is not None:
            self._pool.abort()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.close()


@contextlib.contextmanager
def _signals_ignored_by_children():
    """SIGINT and SIGTERM ignored while a LocalCluster starts its worker processes, which
    inherit that (a spawned Python keeps an ignored SIGINT): Ctrl-C at the terminal, sent
    to the whole process group, reaches this process alone, which stops the cluster (the
    workers printed a KeyboardInterrupt traceback each), as the local pool's workers do."""
    import signal

    previous = {}
    try:
        for number in (signal.SIGINT, signal.SIGTERM):
            previous[number] = signal.signal(number, signal.SIG_IGN)
    except ValueError:  # not the main thread: the signals are not ours to change
        pass
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` is a full disk or an exceeded quota (ENOSPC, EDQUOT): a fault of the
    machine, not of a point, that ends the run (exit 2 naming the file) rather than fail
    each point that follows in turn."""
    import errno

    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


def describe_failure(exc: BaseException) -> str:
    """A failed point's cause in one line. A point Dask cancelled says why: the client
    lost its scheduler, or the worker running it died or left (not only
    "FutureCancelledError … already forgotten")."""
    import concurrent.futures

    detail = " ".join(f"{type(exc).__name__}: {exc}".split())  # distributed's messages span lines
    if isinstance(exc, concurrent.futures.CancelledError):
        if "scheduler-connection-lost" in detail:
            return ("lost with the scheduler: the connection to the Dask scheduler closed (it stopped or the network "
                    "dropped); the next run measures it")
        return (f"lost with its worker: the worker running it died or left the cluster, or the scheduler dropped it "
                f"({detail}); the next run measures it")
    return detail


def quiet_distributed_logs() -> None:
    """distributed's loggers at CRITICAL: a lost scheduler or a Ctrl-C ends the run with
    one line, while the client's reconnect logged tracebacks that said nothing more. Its
    configuration gives some loggers levels of their own (``distributed.client``), so
    each is set, not only the parent."""
    import distributed  # noqa: F401  (its import configures the loggers being quietened)

    names = [n for n in logging.root.manager.loggerDict if n == "distributed" or n.startswith("distributed.")]
    for name in {"distributed", "distributed.client", *names}:
        logging.getLogger(name).setLevel(logging.CRITICAL)


def _ignore_interrupts() -> None:
    """Worker start-up: Ctrl-C at the terminal (and ``kill`` of a job, ``timeout``) goes
    to the whole process group; the parent alone handles SIGINT and SIGTERM (it stops the
    workers with SIGKILL and clears their temporaries)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def _quiet_resource_tracker() -> None:
    """Workers killed on Ctrl-C leave the pool's queue semaphores to multiprocessing's
    resource tracker, which frees them and then warned about them after "interrupted"
    (a UserWarning on every interrupted sweep). The tracker process inherits this
    process's -W options when it starts."""
    import sys

    option = "ignore::UserWarning:multiprocessing.resource_tracker"
    if option not in sys.warnoptions:
        sys.warnoptions.append(option)


def _worker_start(threads: int) -> None:
    """A local worker's start-up: interrupts left to the parent, and Dr.Jit on this
    worker's share of the cores (its threads: a worker of N on C cores has C // N)."""
    from volcaustics.reference.mi_setup import share_cores

    _ignore_interrupts()
    share_cores(threads)


class _LocalPool:
    """``spawn``ed local processes (a fork would inherit the parent's Dr.Jit and GL
    state), started as tasks need them."""

    def __init__(self, workers: int):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self.workers = workers
        _quiet_resource_tracker()
        self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                         initializer=_worker_start, initargs=(max(1, default_workers() // workers),))

    def submit(self, fn, *args, key: str | None = None):
        return self._pool.submit(fn, *args)

    def scattered(self, payload: dict) -> dict:
        return {name: value for name, (_, value) in payload.items()}  # pickled with the task

    def task_key(self, key: str) -> None:
        return None

    def as_completed(self, futures):
        from concurrent.futures import as_completed

        return as_completed(futures)

    def cancel(self, futures) -> None:
        """Nothing is cancelled: a future cancelled while queued made the pool's manager
        thread raise InvalidStateError when the pool was later killed (Ctrl-C; 3.11). The
        batches dropped (at most workers − 1 a stream, beyond a noise target) still render."""

    def abort(self) -> None:
        # Kill first, cancel nothing: the pool then fails every pending future itself (a
        # future cancelled before made its manager thread raise InvalidStateError, 3.11).
        processes = list((getattr(self._pool, "_processes", None) or {}).values())
        for process in processes:
            process.kill()
        for process in processes:  # gone before the caller clears their temporaries
            process.join(timeout=30)

    def close(self) -> None:
        self._pool.shutdown(wait=True)  # after abort: fails the pending futures and frees the queues


class _DaskPool:
    """A Dask client: of a ``LocalCluster`` it starts (``local:N``) or of a running
    scheduler (``tcp://``), one task per worker process at a time."""

    def __init__(self, dask: str):
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:
            raise ExecutorError(f"--dask: dask.distributed is not installed ({exc})") from None
        kind, value = parse_dask(dask)
        quiet_distributed_logs()
        self._cluster = None
        self._futures: list = []
        self._sent: dict = {}
        try:
            if kind == "local":
                with _signals_ignored_by_children():
                    # no dashboard; the scheduler's HTTP server (health, metrics) still starts, at
                    # :8787 with a warning when that port is taken: on the loopback at a free port
                    self._cluster = LocalCluster(n_workers=value, threads_per_worker=1, processes=True,
                                                 dashboard_address=None,
                                                 scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                                 silence_logs=logging.CRITICAL)
                self.client = Client(self._cluster)
            else:
                self.client = Client(value, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise ExecutorError(f"--dask {dask}: cannot reach the scheduler ({exc})") from None
        self.workers = max(1, len(self.client.scheduler_info().get("workers", {})))
        if kind == "local":
            from volcaustics.reference.mi_setup import share_cores

            self.client.run(share_cores, max(1, default_workers() // value))

    def submit(self, fn, *args, key: str | None = None):
        future = self.client.submit(fn, *args, key=key, pure=False, retries=0)
        self._futures.append(future)
        return future

    def scatter(self, value):
        """``value`` sent to the cluster once; tasks that name the future get it there.
        It lives on one worker: if that worker dies the tasks that need it fail (reported,
        exit 1; the next run measures them). Sent to every worker, a scatter to a worker
        killed meanwhile hung (distributed 2026.8). A closed stream is tried again."""
        import time

        for attempt in range(3):
            try:
                return self.client.scatter(value, hash=False, timeout=SCATTER_SECONDS)
            except (OSError, TimeoutError):  # distributed's CommClosedError
                if attempt == 2:
                    raise
                time.sleep(1.0)

    def scattered(self, payload: dict) -> dict:
        """What a task ships (name → (identity, value): its reference, its scene with the
        mesh files) as futures, each value sent once per identity: arrays and meshes travel
        once, not once per point (Dask resolves the futures before the worker runs it)."""
        out = {}
        for name, (identity, value) in payload.items():
            if (name, identity) not in self._sent:
                self._sent[(name, identity)] = self.scatter(value)
            out[name] = self._sent[(name, identity)]
        return out

    def task_key(self, key: str) -> str:
        return f"volcaustics-point-{key}"

    def as_completed(self, futures):
        from dask.distributed import as_completed

        return as_completed(futures)

    def cancel(self, futures) -> None:
        if futures:
            self.client.cancel(list(futures))

    def abort(self) -> None:
        self.cancel(self._futures)

    def close(self) -> None:
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()
