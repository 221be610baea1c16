"""Per-pass GPU times of display frames, read one or more frames late and never waited on.

Each pass is bracketed by two GL timestamps (``glQueryCounter(id, GL_TIMESTAMP)``). A
frame's results are read at a later :meth:`LateTimer.begin_frame`, only once every query
of that frame says it is available, and then with ``GL_QUERY_RESULT_NO_WAIT`` (GL 4.4),
so the CPU never stalls on the GPU (``GL_QUERY_RESULT`` would block; the display frame's
apitrace test checks the calls). The query objects are made once, in a ring of
``frames_in_flight`` slots reused frame after frame; a frame whose results are still
missing when its slot comes round again is dropped, not waited for.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import moderngl

from .gl_entry import gl_function

TIMER_SENTINEL = 4294967295       # 2**32 - 1: a timer query answer that is no elapsed time

TIMESTAMP = 0x8E28                # GL_TIMESTAMP
QUERY_COUNTER_BITS = 0x8864       # GL_QUERY_COUNTER_BITS
QUERY_RESULT_AVAILABLE = 0x8867   # GL_QUERY_RESULT_AVAILABLE
QUERY_RESULT_NO_WAIT = 0x9194     # GL_QUERY_RESULT_NO_WAIT (GL 4.4, ARB_query_buffer_object)
NO_WAIT_SINCE = 440               # moderngl's version_code of GL 4.4


@dataclass
class FrameQueries:
    """One frame's timestamps: ``spans`` holds (pass name, start index, end index) into
    its ring slot's query ids; ``used`` counts the ids taken."""

    number: int
    spans: list[tuple[str, int, int]] = field(default_factory=list)
    used: int = 0


class LateTimer:
    """GPU seconds per pass and display frame, collected frames later without waiting.

    Parameters
    ----------
    ctx : moderngl.Context
        The current context (GL ≥ 4.4 for ``GL_QUERY_RESULT_NO_WAIT``; below that, or
        without the entry points, nothing is measured and ``supported`` is False).
    frames_in_flight : int
        Slots of the ring (≥ 1): frames issued and not yet collected, the one being
        recorded included. A frame still out when its slot is needed again, at the
        ``begin_frame`` ``frames_in_flight`` frames after its own, is dropped and counted
        in ``dropped``; 1 asks each frame's results by the next frame's start.
    history : int
        How many collected frames ``collected`` keeps (the oldest are forgotten), so a
        display loop's memory stays bounded.

    Attributes
    ----------
    method : str
        ``"gl_timestamp_late"``.
    supported : bool
        False where the driver has no usable timestamps (no counter bits, llvmpipe's
        sentinel 4294967295, an end before its start); such times are NaN.
    dropped : int
        Frames whose results were still missing when their ring slot was needed.
    """

    method = "gl_timestamp_late"

    def __init__(self, ctx: moderngl.Context, frames_in_flight: int = 4, history: int = 256):
        if frames_in_flight < 1:
            raise ValueError(f"frames_in_flight must be >= 1, got {frames_in_flight}")
        uint, ids = ctypes.c_uint, ctypes.POINTER(ctypes.c_uint)
        self.gen: Any = gl_function("glGenQueries", None, ctypes.c_int, ids)
        self.delete: Any = gl_function("glDeleteQueries", None, ctypes.c_int, ids)
        self.counter: Any = gl_function("glQueryCounter", None, uint, uint)
        self.query_iv: Any = gl_function("glGetQueryiv", None, uint, uint, ctypes.POINTER(ctypes.c_int))
        self.object_iv: Any = gl_function("glGetQueryObjectiv", None, uint, uint, ctypes.POINTER(ctypes.c_int))
        self.object_ui64v: Any = gl_function("glGetQueryObjectui64v", None, uint, uint,
                                             ctypes.POINTER(ctypes.c_uint64))
        self.flush: Any = gl_function("glFlush", None)
        entries = (self.gen, self.delete, self.counter, self.query_iv, self.object_iv, self.object_ui64v,
                   self.flush)
        self.enabled = ctx.version_code >= NO_WAIT_SINCE and all(fn is not None for fn in entries)
        self.supported = self.enabled and self.counter_bits() > 0
        self.frames_in_flight = frames_in_flight
        self.slots: list[list[int]] = [[] for _ in range(frames_in_flight)]
        self.pending: deque[FrameQueries] = deque()
        self.current: FrameQueries | None = None
        self.measuring = False
        self.frames = 0
        self.dropped = 0
        self.kept: deque[tuple[int, dict[str, float]]] = deque(maxlen=history)

    @property
    def collected(self) -> list[tuple[int, dict[str, float]]]:
        """(frame number from 0, {pass: GPU seconds, NaN where not measurable}) of the
        finished frames collected so far, oldest first (the last ``history``)."""
        return list(self.kept)

    def latest(self) -> tuple[int, dict[str, float]] | None:
        """The newest collected frame, or None before the first."""
        return self.kept[-1] if self.kept else None

    @property
    def in_flight(self) -> int:
        """Frames ended and not yet collected (at most ``frames_in_flight``)."""
        return len(self.pending)

    def counter_bits(self) -> int:
        """Bits of the driver's timestamp counter (0: no timestamps)."""
        bits = ctypes.c_int(0)
        self.query_iv(TIMESTAMP, QUERY_COUNTER_BITS, ctypes.byref(bits))
        return bits.value

    def begin_frame(self) -> None:
        """Collect every older frame whose results are all available, drop the one whose
        slot this frame needs if it is still out, and start frame number ``frames``."""
        if self.current is not None:
            raise RuntimeError("begin_frame() before the previous frame's end_frame()")
        self.collect()
        while self.pending and self.pending[0].number <= self.frames - len(self.slots):
            self.pending.popleft()  # its slot's queries are about to be reissued
            self.dropped += 1
            self.collect()  # frames behind it may be ready
        self.current = FrameQueries(self.frames)

    def end_frame(self) -> None:
        """Finish the frame and submit its work (``glFlush``, which does not wait: without a
        swap nothing else may send it, and its queries would never become available); its
        results are read at a later :meth:`begin_frame`."""
        if self.current is None:
            raise RuntimeError("end_frame() without begin_frame()")
        if self.enabled:
            self.flush()
            self.pending.append(self.current)
        self.current = None
        self.frames += 1

    @contextlib.contextmanager
    def measure(self, name: str) -> Iterator[None]:
        """Time the pass ``name`` (the GL work issued in the block); a name repeated in a
        frame adds up. Passes never nest."""
        frame = self.current
        if frame is None:
            raise RuntimeError(f"measure({name!r}) outside begin_frame()/end_frame()")
        if self.measuring:
            raise RuntimeError(f"measure({name!r}) inside another pass: passes never nest")
        ids = self.slot_ids(frame, 2) if self.enabled else []
        if ids:
            self.counter(ids[frame.used], TIMESTAMP)
        self.measuring = True
        try:
            yield
        finally:
            self.measuring = False
            if ids:
                self.counter(ids[frame.used + 1], TIMESTAMP)
                frame.spans.append((name, frame.used, frame.used + 1))
                frame.used += 2

    def slot_ids(self, frame: FrameQueries, more: int) -> list[int]:
        """The query ids of ``frame``'s ring slot with room for ``more``; every slot grows
        (one glGenQueries) only when a frame needs more than any frame before it."""
        ids = self.slots[frame.number % len(self.slots)]
        if frame.used + more > len(ids):
            grow = max(len(ids), frame.used + more - len(ids))
            made = (ctypes.c_uint * (grow * len(self.slots)))()
            self.gen(len(made), made)
            for i, slot in enumerate(self.slots):
                slot.extend(made[i * grow:(i + 1) * grow])
        return ids

    def collect(self) -> None:
        """Move the oldest pending frames whose queries are all available to ``collected``
        (in order: it stops at the first frame still out)."""
        while self.pending and self.available(self.pending[0]):
            frame = self.pending.popleft()
            self.kept.append((frame.number, self.seconds(frame)))

    def available(self, frame: FrameQueries) -> bool:
        """Whether every query of ``frame`` has its result (asked newest first, the
        likeliest to be out; GL_QUERY_RESULT_AVAILABLE never waits)."""
        ids = self.slots[frame.number % len(self.slots)]
        flag = ctypes.c_int(0)
        for index in reversed(range(frame.used)):
            self.object_iv(ids[index], QUERY_RESULT_AVAILABLE, ctypes.byref(flag))
            if not flag.value:
                return False
        return True

    def seconds(self, frame: FrameQueries) -> dict[str, float]:
        """{pass: GPU seconds} of an available frame, read with GL_QUERY_RESULT_NO_WAIT."""
        ids = self.slots[frame.number % len(self.slots)]
        stamps = []
        value = ctypes.c_uint64(0)
        for index in range(frame.used):
            self.object_ui64v(ids[index], QUERY_RESULT_NO_WAIT, ctypes.byref(value))
            stamps.append(int(value.value))
        times: dict[str, float] = {}
        for name, start, end in frame.spans:
            elapsed = self.elapsed(stamps[start], stamps[end])
            times[name] = times.get(name, 0.0) + elapsed
        return times

    def elapsed(self, start: int, end: int) -> float:
        """Seconds between two timestamps in ns; NaN (and ``supported`` False) for the
        driver's sentinel, an end before its start or a driver without timestamps."""
        if TIMER_SENTINEL in (start, end) or end < start:
            self.supported = False
        return (end - start) / 1e9 if self.supported else math.nan

    def release(self) -> None:
        """Delete the query objects; the timer measures nothing afterwards."""
        ids = [i for slot in self.slots for i in slot]
        if self.enabled and ids:
            self.delete(len(ids), (ctypes.c_uint * len(ids))(*ids))
        self.slots = [[] for _ in self.slots]
        self.pending.clear()
        self.enabled = False
