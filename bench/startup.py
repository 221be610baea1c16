"""How fast a command answers before it does any work.

    .venv/bin/python bench/startup.py [--runs 5]

Times, as a user would start them (the installed ``volcaustics`` script, a fresh
interpreter each run): ``volcaustics --help``, ``volcaustics measure --help`` and
``volcaustics measure --frob`` (an unknown flag: exit 2), and beside them ``git --help``
and ``dask --help`` as anchors. Prints the median and the spread of ``--runs`` runs; the
budget is 0.5 s for each of ours (a quiet machine: these machines are shared, so read the
median beside the anchors). ``tests/reports/test_startup.py`` checks what makes it fast:
the parsers import no Mitsuba, Dr.Jit, moderngl, pandas or scipy.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import time

BIN = os.path.dirname(sys.executable)
COMMANDS = {
    "volcaustics --help": [os.path.join(BIN, "volcaustics"), "--help"],
    "volcaustics measure --help": [os.path.join(BIN, "volcaustics"), "measure", "--help"],
    "volcaustics measure --frob": [os.path.join(BIN, "volcaustics"), "measure", "sphere1", "-o", "runs/startup",
                                   "--frob"],
    "git --help (anchor)": ["git", "--help"],
    "dask --help (anchor)": [os.path.join(BIN, "dask"), "--help"],
}
BUDGET_S = 0.5


def timed(argv: list) -> tuple:
    """(seconds, exit code) of one run of ``argv``, its output discarded."""
    t0 = time.perf_counter()
    code = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    return time.perf_counter() - t0, code


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5, help="runs per command (default 5)")
    args = parser.parse_args()
    over = []
    for name, argv in COMMANDS.items():
        if shutil.which(argv[0]) is None:
            print(f"{name:<30} not installed here")
            continue
        timed(argv)  # the first run warms the file cache
        runs = [timed(argv) for _ in range(args.runs)]
        seconds = [s for s, _ in runs]
        median = statistics.median(seconds)
        print(f"{name:<30} median {median:.3f} s (min {min(seconds):.3f}, max {max(seconds):.3f}), "
              f"exit {runs[0][1]}")
        if name.startswith("volcaustics") and median > BUDGET_S:
            over.append(name)
    if over:
        print(f"over the {BUDGET_S} s budget: {', '.join(over)}")
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
