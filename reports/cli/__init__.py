"""The ``volcaustics`` command line: one small module per command (``cli/<command>.py``:
``register`` adds its parser, ``run`` parses nothing more and calls the libraries).

Bad input (a scene, a parameter, settings, a path, a spec: every error derived from
``volcaustics.infra.errors.InputError``) prints on one or two lines and exits 2, never a
traceback; Ctrl-C exits 130, SIGTERM 143.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

EXIT_USAGE = 2
TOOLS = ("doctor", "scenes", "approx", "reference", "export", "measure")  # the commands that are not studies


def commands() -> tuple[str, ...]:
    """Every command's module under ``reports.cli``, in ``--help`` order: the tools, every
    study of the registry (``reports.studies.registry``: its ``command``) and the report."""
    from volcaustics.reports.studies.registry import studies

    return (*(f"volcaustics.reports.cli.{name}" for name in TOOLS), *(s.command for s in studies()),
            "volcaustics.reports.cli.report")


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command (imports the command modules: call it under
    :func:`main`'s Ctrl-C handler)."""
    import importlib

    parser = argparse.ArgumentParser(prog="volcaustics", description=(
        "Validation harness for Real-time Volume Caustics with Image-based Photon Tracing: "
        "the paper's GPU method beside Mitsuba 3 ground truth."))
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in commands():
        importlib.import_module(module).register(sub)
    return parser


def interrupted(exc: BaseException | None) -> bool:
    """Whether ``exc`` is Ctrl-C as Dr.Jit/Mitsuba pass it on: a KeyboardInterrupt raised
    in Python code that C++ called (an integrator's method, a symbolic loop's body)
    comes back as a RuntimeError naming it or chained to it."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, KeyboardInterrupt) or any(name in str(exc) for name in ("KeyboardInterrupt", "Interrupted")):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM came (``signum``): raised where the command was, so every
    ``finally`` and every handler of KeyboardInterrupt (a sweep stopping its workers)
    runs as for Ctrl-C; the exit code is 128 + signum (130, 143)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command; exit 130 whenever Ctrl-C came (143 for SIGTERM), also during
    the imports and when Python dropped the KeyboardInterrupt ("Exception ignored in
    ...": raised inside a finalizer or weakref callback).

    SIGINT and SIGTERM (whichever thread takes them, Python handles them here) raise
    :class:`Interrupted` where the command is, so its temporaries go and the previous
    outputs stay. Start-up (the command modules, the libraries and the native
    extensions the command declares in ``NATIVE``: Dr.Jit, Mitsuba, moderngl) holds
    them: one that came is recorded, not raised, so no interrupt lands inside an
    extension's initialisation (it surfaced there as an ImportError, a NameError or a
    SystemError, or aborted the interpreter); once start-up is done it ends the run.
    A signal ignored when the command starts (``nohup``, ``cmd &``) stays ignored. When
    an interrupt left a native call running (``infra.interrupts.interruptible``), the
    process ends with ``os._exit`` after the command's cleanup."""
    import signal

    came = []
    holding = [True]

    def on_signal(signum, frame):
        came.append(signum)
        if not holding[0]:
            raise Interrupted(signum)

    def started():
        holding[0] = False
        if came:
            raise Interrupted(came[0])

    def on_unraisable(unraisable: sys.UnraisableHookArgs) -> None:
        # an interrupt raised inside a finalizer or a weakref callback (importlib's module
        # locks) is dropped by Python with "Exception ignored in …" and a traceback: it came
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            came.append(getattr(unraisable.exc_value, "signum", signal.SIGINT))
        else:
            hook(unraisable)

    hook, sys.unraisablehook = sys.unraisablehook, on_unraisable
    previous = {}
    for number in (signal.SIGINT, signal.SIGTERM):
        try:
            if signal.getsignal(number) is not signal.SIG_IGN:
                previous[number] = signal.signal(number, on_signal)
        except ValueError:  # not the main thread: signals are not ours to handle
            break
    if not previous:
        holding[0] = False
    try:
        code = _run(argv, started)
    except KeyboardInterrupt:
        code = None
    except Exception:
        if not came:  # an error of an interrupted start-up or shutdown is the interrupt's
            raise
        code = None
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        sys.unraisablehook = hook
    if code is None or (came and code < 128):
        print("volcaustics: interrupted", file=sys.stderr)
        code = 128 + (came[0] if came else signal.SIGINT)
    return _ending(code)


def _ending(code: int) -> int:
    """``code``; but when an interrupt left a native call running, end the process
    here (the interpreter's shutdown would wait for it, or tear down under it)."""
    from volcaustics.infra.interrupts import native_work_abandoned

    if native_work_abandoned():
        import os

        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


def _run(argv, started=lambda: None) -> int | None:
    """The command's exit code; None when it was interrupted. The command modules, the
    libraries (about a second of imports) and the native extensions the command's
    module names in ``NATIVE`` load here; then ``started()`` (main: Ctrl-C no longer
    held)."""
    import importlib

    from volcaustics.infra.errors import InputError

    args = build_parser().parse_args(argv)
    for name in getattr(sys.modules[args.func.__module__], "NATIVE", ()):
        importlib.import_module(name)
    started()
    try:
        return args.func(args)
    except InputError as exc:
        print(f"volcaustics: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except RuntimeError as exc:
        if not interrupted(exc):
            raise
        return None
    except BrokenPipeError:  # output piped into `head` and closed: not an error of ours
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a file or folder the checks up front could not foresee (disk full, permissions)
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"volcaustics: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE



if __name__ == "__main__":
    sys.exit(main())
