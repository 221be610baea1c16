"""The ``--dask`` address (``local:N`` or ``tcp://HOST:PORT``): its parsing, and the
pre-flight check of a running scheduler before anything renders (connection, handshake
and a first worker, each bounded by the wall clock)."""

from __future__ import annotations

from volcaustics.infra.errors import InputError


class ExecutorError(InputError):
    """An executor that cannot start (an unreachable scheduler, Dask missing): exit 2."""


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


WORKER_WAIT = 60.0  # --dask-wait default: seconds a scheduler may take to have a worker


def check_reachable(address: str, timeout: float = 5.0, workers_wait: float = WORKER_WAIT) -> None:
    """For ``tcp://HOST:PORT``: ExecutorError (exit 2, naming the address and what was
    wrong) unless a TCP connection opens within ``timeout`` s, the peer answers as a Dask
    scheduler within ``timeout`` s more (a stopped scheduler, an HTTP server or a port that
    never answers once hung here or failed with a numpy MemoryError), and it has a worker
    within ``workers_wait`` s — all before anything renders. ``local:N`` needs nothing."""
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
    _check_scheduler(address, value, timeout, workers_wait)


def _check_scheduler(address: str, value: str, timeout: float, workers_wait: float) -> None:
    """The handshake and the worker count, in a thread bounded by the wall clock (the
    client's own timeout does not bound a handshake that never completes)."""
    import threading

    outcome: dict = {}
    answered = threading.Event()

    def probe():
        try:
            from dask.distributed import Client

            client = Client(value, timeout=f"{timeout}s", set_as_default=False)
            try:
                outcome["identity"] = client.scheduler_info().get("type")
                answered.set()
                try:
                    client.wait_for_workers(1, timeout=workers_wait)
                except TimeoutError:
                    outcome["workers"] = 0
            finally:
                client.close(timeout=timeout)
        except BaseException as exc:  # noqa: BLE001 (a MemoryError from reading an HTTP reply too)
            outcome["error"] = exc
        answered.set()

    thread = threading.Thread(target=probe, daemon=True, name="dask-probe")
    thread.start()
    if answered.wait(2 * timeout + 2.0):  # the handshake, then the wait for a worker
        thread.join(workers_wait + timeout + 5.0)
    fix = "start a scheduler (`dask scheduler`) and workers (`dask worker ADDRESS --nthreads 1`), or use --dask local:N"
    if not answered.is_set() or thread.is_alive():
        raise ExecutorError(f"--dask {address}: the port accepts connections but no Dask scheduler answered within "
                            f"{timeout:g} s (a stopped scheduler, or another server): {fix}")
    if "error" in outcome:
        exc = outcome["error"]
        what = "a reply that is not Dask's" if isinstance(exc, MemoryError) else f"{type(exc).__name__}: {exc}"
        raise ExecutorError(f"--dask {address}: not a Dask scheduler, or it did not answer ({what}): {fix}")
    if outcome.get("workers") == 0:
        raise ExecutorError(f"--dask {address}: the scheduler has no worker after {workers_wait:g} s "
                            f"(--dask-wait): start workers (`dask worker {address} --nthreads 1`)")
