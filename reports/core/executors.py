"""Where a sweep's points run: local worker processes (default) or Dask distributed.

GL contexts and Mitsuba variants belong to a process, so every executor runs one
task per worker process at a time: a local pool of ``spawn``ed processes (a fork
would inherit the parent's Dr.Jit and GL state), or Dask workers with one thread
each (``--dask local:N`` starts a ``LocalCluster`` of N such processes; for
``--dask tcp://HOST:PORT`` start the workers with ``--nthreads 1``, and
``reports.runner.run_point`` also serialises the tasks of one process). Results come
back as they finish; Ctrl-C cancels what has not started, stops the workers and
re-raises KeyboardInterrupt (finished points are already in the store).
"""

from __future__ import annotations

import os

from volcaustics.infra.errors import InputError


class ExecutorError(InputError):
    """An executor that cannot start (an unreachable scheduler, Dask missing): exit 2."""


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def parse_dask(address: str) -> tuple:
    """("local", N) for ``local:N``, ("tcp", address) for ``tcp://HOST:PORT``; ValueError else."""
    if address.startswith("local:"):
        try:
            n = int(address.split(":", 1)[1])
        except ValueError:
            n = 0
        if n < 1:
            raise ValueError(f"--dask {address!r}: expected local:N with N ≥ 1 worker processes")
        return "local", n
    if address.startswith("tcp://") and len(address) > len("tcp://"):
        return "tcp", address
    raise ValueError(f"--dask {address!r}: expected tcp://HOST:PORT (a running scheduler) or local:N")


def check_reachable(address: str, timeout: float = 5.0) -> None:
    """For ``tcp://HOST:PORT``: ExecutorError unless a TCP connection to the scheduler
    opens within ``timeout`` s — checked before anything renders (connecting the Dask
    client waits until the points are submitted, after the references). ``local:N``
    needs nothing."""
    import socket
    from urllib.parse import urlsplit

    kind, value = parse_dask(address)
    if kind != "tcp":
        return
    try:
        url = urlsplit(value)
        host, port = url.hostname, url.port
    except ValueError as exc:
        raise ExecutorError(f"--dask {address}: {exc}") from None
    if not host or port is None:
        raise ExecutorError(f"--dask {address!r}: expected tcp://HOST:PORT")
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        raise ExecutorError(f"--dask {address}: cannot reach the scheduler ({exc.strerror or exc}): start it "
                            f"(`dask scheduler`, workers with --nthreads 1) or use --dask local:N") from None


def run_tasks(fn, tasks: list, *, total: int, done: int = 0, workers: int | None = None, dask: str | None = None,
              progress: bool = True, desc: str = "sweep"):
    """Yield ``fn(task)``'s results (dicts; a failed task gives {"key", "error"}) as
    they finish, with one progress bar (``desc``) of points done / ``total`` (``done`` already)."""
    from tqdm import tqdm

    bar = tqdm(total=total, initial=done, desc=desc, unit="point", disable=not progress, smoothing=0.1)
    try:
        if not tasks:
            return
        results = _dask(fn, tasks, dask) if dask else _local(fn, tasks, workers)
        for result in results:
            bar.update()
            if result.get("error"):
                bar.write(f"{desc}: point {result['key'][:12]} failed: {result['error']}")
            yield result
    finally:
        bar.close()


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


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


def _local(fn, tasks, workers):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    n = min(workers or default_workers(), len(tasks))
    _quiet_resource_tracker()
    pool = ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_ignore_interrupts)
    futures = {pool.submit(fn, task): task["key"] for task in tasks}
    try:
        for future in as_completed(futures):
            try:
                yield future.result()
            except Exception as exc:  # a point that fails is reported; the others go on
                yield {"key": futures[future], "error": _describe(exc)}
    except BaseException:
        # Kill first, cancel nothing: the pool then fails every pending future itself (a
        # future cancelled before made its manager thread raise InvalidStateError, 3.11).
        processes = list(getattr(pool, "_processes", {}).values())
        for process in processes:
            process.kill()
        for process in processes:  # gone before the caller clears their temporaries
            process.join(timeout=30)
        pool.shutdown(wait=True)  # the manager thread fails the pending futures and frees the queues
        raise
    pool.shutdown(wait=True)


def _scattered(client, tasks: list) -> list:
    """The tasks with each shipped reference (``task["reference"]``) sent to the cluster
    once and named by its future: a reference's arrays travel once, not once per point
    (Dask resolves the future in the task before the worker runs it)."""
    sent = {}
    out = []
    for task in tasks:
        if "reference" in task:
            key = task["reference_key"]
            if key not in sent:
                sent[key] = client.scatter(task["reference"], hash=False)
            task = {**task, "reference": sent[key]}
        out.append(task)
    return out


def _dask(fn, tasks, dask):
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as exc:
        raise ExecutorError(f"--dask: dask.distributed is not installed ({exc})") from None

    kind, value = parse_dask(dask)
    cluster = None
    try:
        if kind == "local":
            cluster = LocalCluster(n_workers=value, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(value, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise ExecutorError(f"--dask {dask}: cannot reach the scheduler ({exc})") from None
    futures = []
    try:
        tasks = _scattered(client, tasks)
        futures = [client.submit(fn, task, key=f"volcaustics-point-{task['key']}", pure=False, retries=0)
                   for task in tasks]
        keys = {f.key: t["key"] for f, t in zip(futures, tasks)}
        for future in as_completed(futures):
            try:
                yield future.result()
            except Exception as exc:
                yield {"key": keys[future.key], "error": _describe(exc)}
    except BaseException:
        client.cancel(futures)
        raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
