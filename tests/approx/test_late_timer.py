"""LateTimer's ring on the session's context, with the driver's answers replaced where a
case needs them (a frame never ready, the timer sentinel, known timestamps): it drops
rather than waits, reuses its queries, sums a repeated pass and turns the sentinel into
NaN; and the debug group stays balanced when its block raises."""

from __future__ import annotations

import ctypes
import math

import pytest

from volcaustics.approx.debug_groups import DISPLAY_FRAME, debug_group
from volcaustics.approx.gl_entry import current_gl_version, gl_function
from volcaustics.approx.late_timer import TIMER_SENTINEL, LateTimer

DEBUG_GROUP_STACK_DEPTH = 0x826D  # GL_DEBUG_GROUP_STACK_DEPTH


def run_frames(timer: LateTimer, count: int, passes=("a", "b", "a")) -> None:
    for _ in range(count):
        timer.begin_frame()
        for name in passes:
            with timer.measure(name):
                pass
        timer.end_frame()


def fake_stamps(timer: LateTimer, stamp) -> None:
    """Answer every timestamp read with ``stamp(query id)`` in ns."""
    def read(query, pname, out):
        out._obj.value = stamp(query)
    timer.object_ui64v = read


@pytest.fixture
def timer(ctx):
    made = LateTimer(ctx, frames_in_flight=3)
    assert made.enabled, "the session's context has GL 4.4 and the query entry points"
    yield made
    made.release()


def test_a_frame_never_ready_is_dropped_not_waited_for_and_the_ring_is_reused(ctx, timer, monkeypatch):
    monkeypatch.setattr(timer, "available", lambda frame: False)
    run_frames(timer, 1)
    ring = [list(slot) for slot in timer.slots]
    run_frames(timer, 7)
    assert timer.slots == ring, "no query made after the first frame"
    assert timer.collected == [] and timer.in_flight == 3 and timer.dropped == 5
    monkeypatch.undo()
    fake_stamps(timer, lambda query: 1000 * query)
    ctx.finish()  # the test waits, so that the three frames in flight are all ready
    timer.begin_frame()
    assert timer.in_flight == 0 and timer.dropped == 5
    assert [number for number, _ in timer.collected] == [5, 6, 7] and timer.latest()[0] == 7
    timer.end_frame()


def test_a_repeated_pass_adds_up_and_frames_are_read_late(ctx, timer):
    fake_stamps(timer, lambda query: 1000 * query)
    run_frames(timer, 1)
    ids = timer.slots[0]
    assert len(ids) >= 6
    ctx.finish()  # the test waits, so that the frame is ready
    timer.begin_frame()
    frame, times = timer.latest()
    assert frame == 0
    expected_a = (ids[1] - ids[0] + ids[5] - ids[4]) * 1e-6
    assert times == pytest.approx({"a": expected_a, "b": (ids[3] - ids[2]) * 1e-6})
    assert timer.supported and timer.method == "gl_timestamp_late"


@pytest.mark.parametrize("stamp", [lambda q: TIMER_SENTINEL, lambda q: 10**9 - q])
def test_the_sentinel_or_an_end_before_its_start_is_nan_and_unsupported(ctx, timer, stamp):
    fake_stamps(timer, stamp)
    run_frames(timer, 1, passes=("a",))
    ctx.finish()  # the test waits, so that the frame is ready
    timer.begin_frame()
    assert math.isnan(timer.latest()[1]["a"]) and not timer.supported
    assert math.isnan(timer.elapsed(1, 2)), "once unsupported, every time is NaN"


def test_real_timestamps_arrive_late_without_a_wait(timer):
    """On the session's driver (llvmpipe here): frames are collected in order, each time
    finite and ≥ 0 where the driver has timestamps, NaN where it has not."""
    for _ in range(12):
        run_frames(timer, 1)
    assert timer.collected or timer.dropped
    numbers = [number for number, _ in timer.collected]
    assert numbers == sorted(numbers) and len(numbers) + timer.dropped + timer.in_flight == 12
    for _, times in timer.collected:
        assert set(times) == {"a", "b"}
        assert all((value >= 0) if timer.supported else math.isnan(value) for value in times.values())


def test_passes_never_nest_and_live_in_a_frame(timer):
    with pytest.raises(RuntimeError, match="outside"):
        with timer.measure("a"):
            pass
    timer.begin_frame()
    with pytest.raises(RuntimeError, match="never nest"):
        with timer.measure("a"):
            with timer.measure("b"):
                pass
    with pytest.raises(RuntimeError, match="before the previous"):
        timer.begin_frame()
    timer.end_frame()


def test_the_debug_group_is_popped_when_its_block_raises(ctx):
    assert current_gl_version() >= (4, 3)
    get = gl_function("glGetIntegerv", None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
    depth = ctypes.c_int(-1)
    with pytest.raises(KeyError):
        with debug_group(DISPLAY_FRAME):
            get(DEBUG_GROUP_STACK_DEPTH, ctypes.byref(depth))
            assert depth.value == 2  # the default group is the first on the stack
            raise KeyError("inside")
    get(DEBUG_GROUP_STACK_DEPTH, ctypes.byref(depth))
    assert depth.value == 1
