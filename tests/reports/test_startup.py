"""A command answers ``--help`` and a bad flag without loading what does the work: the
parsers (``reports/cli/<command>.py`` at import, ``register``) import no Mitsuba, Dr.Jit,
moderngl, pandas or scipy; the command's implementation loads when it is dispatched.
They took 3.3–4.0 s before (the parser imported 172 of 180 modules, scipy.stats among
them); ``bench/startup.py`` times them."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("mitsuba", "drjit", "moderngl", "pandas", "scipy")
# Runs the CLI on argv in a fresh interpreter and prints (exit code, the heavy modules
# loaded); with a module name in argv[1], importing that command module also imports
# pandas (the negative control: a parser module that loads a heavy library).
PROBE = """
import importlib.abc, json, sys
heavy, planted, argv = json.loads(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3])

class Plant(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == planted:
            import pandas  # noqa: F401
        return None

sys.meta_path.insert(0, Plant())
from volcaustics.reports.cli import main
try:
    code = main(argv)
except SystemExit as exc:
    code = exc.code
print(json.dumps([code, sorted(m for m in heavy if m in sys.modules)]))
"""


def _loaded(argv: list, planted: str = "") -> tuple:
    run = subprocess.run([sys.executable, "-c", PROBE, json.dumps(HEAVY), planted, json.dumps(argv)],
                         capture_output=True, text=True, timeout=120)
    code, heavy = json.loads(run.stdout.strip().splitlines()[-1])
    return code, heavy


@pytest.mark.parametrize("argv, code", [
    (["--help"], 0),
    (["measure", "--help"], 0),
    (["sweep", "--help"], 0),
    (["report", "--help"], 0),
    (["measure", "sphere1", "-o", "out", "--frob"], 2),
])
def test_help_and_a_bad_flag_load_no_heavy_library(argv, code):
    assert _loaded(argv) == (code, [])


def test_a_parser_module_that_loads_a_heavy_library_is_caught():
    """Negative control: the same probe, with the frames command's module importing pandas."""
    assert _loaded(["--help"], planted="volcaustics.reports.cli.frames") == (0, ["pandas"])


def test_exact_steps_is_the_reference_path_length():
    """measurement.EXACT_STEPS is written out (its module loads with every parser; the
    other loads numpy): it must equal scenes.formats.PATH_INTERACTIONS."""
    from volcaustics.experiment.measurement import EXACT_STEPS
    from volcaustics.scenes.formats import PATH_INTERACTIONS

    assert EXACT_STEPS == PATH_INTERACTIONS
