"""Where a reference's batches render: in this process, one after another
(:class:`InProcess`), or on a pool of workers (:class:`Pooled`: local processes or a
Dask cluster, ``reports.measuring.pools.executors``), all wanted batches of every reference of
the run at once. Either way the render reads the batches in the order the serial
path renders them, and adds them in that order (``tasks.add_batch``), so the sums,
the per-batch totals and the group sums are the serial path's.
"""

from __future__ import annotations

import uuid
from collections import deque
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any, Protocol

from .tasks import forget, render_batch

if TYPE_CHECKING:
    from ..request import RenderRequest


class BatchPool(Protocol):
    """What :class:`Pooled` uses of a pool (``reports.measuring.pools.executors``): its
    ``workers``, ``submit`` (a future with ``result()``) and ``cancel``."""

    @property
    def workers(self) -> int: ...

    def submit(self, fn: Callable[..., Any], *args: Any, key: str | None = None) -> Any: ...

    def cancel(self, futures: list) -> None: ...


class InProcess:
    """Each batch rendered here when it is read (the serial path)."""

    spare = 1

    def want(self, key: str, request: RenderRequest, batches: Iterable[tuple[str, int]]) -> None:
        """Nothing ahead: a batch renders when it is read."""

    def images(self, key: str, request: RenderRequest, stream: str, index: int) -> tuple:
        return render_batch(key, request, stream, index)

    def drop(self, key: str) -> None:
        forget(key)


class BatchError(RuntimeError):
    """A batch failed where it rendered (its worker died, Mitsuba raised)."""


class Pooled:
    """Batches rendered on ``pool`` (an open ``reports.measuring.pools.executors`` pool: ``submit``,
    ``cancel``, ``workers``), submitted in the order they are wanted and
    read in the order the render needs them. At most ``ahead`` (default: twice the
    workers) are out at once, rendering or done and not read yet, so the images held
    here stay bounded however many references the run has; a batch the render waits
    for goes out at once."""

    def __init__(self, pool: BatchPool, ahead: int | None = None) -> None:
        self.pool = pool
        self.spare = max(1, pool.workers)  # batches wanted ahead beyond a render's minimum (noise targets)
        self.ahead = ahead or 2 * self.spare
        self.requests: dict = {}   # key -> its request
        self.out: dict = {}        # (key, stream, index) -> future
        self.queue: deque = deque()

    def want(self, key: str, request: RenderRequest, batches: Iterable[tuple[str, int]]) -> None:
        """Queue ``batches`` ((stream, index), in the order they will be read) of ``request``.
        The request goes with each batch task, not scattered once: a task's own arguments
        stay with the scheduler, which sends them again when a worker dies under it, while
        scattered data lives on one worker (and a scatter to a worker killed meanwhile
        hung, distributed 2026.8)."""
        if key not in self.requests:
            self.requests[key] = request
        queued = set(self.queue)
        for stream, index in batches:
            item = (key, stream, index)
            if item not in self.out and item not in queued:
                self.queue.append(item)
                queued.add(item)
        self._fill()

    def images(self, key: str, request: RenderRequest, stream: str, index: int) -> tuple:
        """Batch ``index`` of ``stream``, waited for (sent now if it is not out yet)."""
        item = (key, stream, index)
        if item not in self.out:
            self.want(key, request, ())
            if item in self.queue:
                self.queue.remove(item)
            self._submit(item)
        future = self.out.pop(item)
        try:
            result = future.result()
        except Exception as exc:  # a worker that died, a render that raised: the reference cannot be completed
            raise BatchError(f"batch {index} of the {stream} stream failed on a worker: "
                             f"{type(exc).__name__}: {exc}") from exc
        self._fill()
        return result

    def drop(self, key: str) -> None:
        """The render of ``key`` is over: its batches not read are cancelled."""
        self.queue = deque(item for item in self.queue if item[0] != key)
        unread = [item for item in self.out if item[0] == key]
        self.pool.cancel([self.out.pop(item) for item in unread])
        self.requests.pop(key, None)
        self._fill()

    def _fill(self) -> None:
        while self.queue and len(self.out) < self.ahead:
            self._submit(self.queue.popleft())

    def _submit(self, item: tuple) -> None:
        key, stream, index = item
        name = f"volcaustics-batch-{key[:16]}-{stream}-{index}-{uuid.uuid4().hex[:8]}"
        self.out[item] = self.pool.submit(render_batch, key, self.requests[key], stream, index, key=name)
