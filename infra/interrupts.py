"""Interrupts (Ctrl-C's SIGINT and SIGTERM) held back where they would do harm, and
native calls that do not hold them back.

A signal sent to the process (what a terminal, ``kill`` and CI send) is taken by
whichever thread the kernel picks: a Dr.Jit, llvmpipe or executor thread as often as
the main one, so blocking it in the main thread (``pthread_sigmask``) holds nothing.
Python runs its handlers in the main thread, whichever thread took the signal; so
:func:`interrupts_held` swaps the Python-level handlers for ones that only record, and
delivers what came after the block, in order, to the handlers that were there before.

A native call (a Mitsuba render, Dr.Jit's kernel launch) never returns to Python until
it is done, so a handler waits as long as it runs — forever when it hangs.
:func:`interruptible` runs it in a worker thread while the main thread waits, where
handlers run: an interrupt stops the wait; the abandoned call goes on in its thread,
and :func:`native_work_abandoned` tells the command line to end the process without
the interpreter's shutdown (which would wait for, or tear down under, that thread).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from typing import Any, ParamSpec, TypeVar

_P = ParamSpec("_P")
_T = TypeVar("_T")

HELD = ("SIGINT", "SIGTERM")
_abandoned = threading.Event()


@contextlib.contextmanager
def interrupts_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back for the block (a set of renames): one that came
    meanwhile, in whichever thread, is recorded and delivered right after the block to
    the handler that was in place (Ctrl-C: KeyboardInterrupt; SIGTERM: its handler, or
    the default that ends the process). A signal that was ignored stays ignored. Python
    handles signals in the main thread only; elsewhere the block runs as is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []
    previous: dict[int, Any] = {}
    for name in HELD:
        number = getattr(signal, name, None)
        if number is None or signal.getsignal(number) in (signal.SIG_IGN, None):
            continue
        previous[number] = signal.signal(number, lambda signum, frame: came.append(signum))
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        for number in came:
            signal.raise_signal(number)  # the handler put back runs now, as if it came now


def interruptible(call: Callable[_P, _T], *args: _P.args, **kwargs: _P.kwargs) -> _T:
    """``call(*args, **kwargs)`` in a worker thread while this thread waits where
    signal handlers run; returns its result or raises its exception. An interrupt
    (KeyboardInterrupt, or whatever a SIGTERM handler raises) ends the wait at once and
    leaves the call running in its daemon thread (:func:`native_work_abandoned`, also
    set when it had just returned: the library may be stopping threads of its own).
    Outside the main thread, calls directly (no handler would run there anyway)."""
    if threading.current_thread() is not threading.main_thread():
        return call(*args, **kwargs)
    outcome: dict[str, Any] = {}
    done = threading.Event()  # not Thread.is_alive: an interrupted join marks the thread stopped (bpo-45274)

    def work() -> None:
        try:
            outcome["value"] = call(*args, **kwargs)
        except BaseException as exc:  # handed to the waiting thread, raised there
            outcome["error"] = exc
        finally:
            done.set()

    threading.Thread(target=work, name=f"native {getattr(call, '__name__', 'call')}", daemon=True).start()
    try:
        while not done.wait(0.05):  # handlers run between waits
            pass
    except BaseException:
        # Also when the call has just returned: a library that saw the signal too (Mitsuba's
        # own SIGINT handler winds its render down) may still be stopping its threads, and
        # the interpreter's shutdown then aborted ("terminate called without an active exception").
        _abandoned.set()
        raise
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def native_work_abandoned() -> bool:
    """Whether an interrupt left a native call running (:func:`interruptible`): the
    process must then end with ``os._exit`` once its files are in order."""
    return _abandoned.is_set()
