"""``volcaustics doctor``: can this machine run the harness? Exit 0, or 2 with the fix."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse

EXIT_USAGE = 2


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("doctor", help="check GL, libLLVM and Mitsuba variants; exit 2 with the fix if unusable")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from volcaustics.reports.measuring.machine_check import format_report, run_doctor

    report = run_doctor()
    print(format_report(report))
    return 0 if report.ok else EXIT_USAGE
