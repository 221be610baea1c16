"""The annotation check (scripts/check_annotations.py, run by make lint): every public
function of the package annotates its parameters and its return."""

from __future__ import annotations

import os
import subprocess
import sys

from tests.shared import load_script

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "scripts", "check_annotations.py")


def test_every_public_function_of_the_package_is_annotated():
    run = subprocess.run([sys.executable, SCRIPT], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:]


def test_a_public_function_without_annotations_is_flagged():
    """Negative control: a missing parameter or return annotation of a function or of a
    public class's method is named; self, private names, private classes and nested
    functions are not."""
    source = ("def full(a: int, *rest: str, **kw: float) -> int:\n"
              "    def nested(x):\n        return x\n    return a\n"
              "def no_return(a: int):\n    pass\n"
              "def no_param(a, b: int) -> None:\n    pass\n"
              "def _private(a):\n    pass\n"
              "class Public:\n"
              "    def method(self, x) -> int:\n        return x\n"
              "    @staticmethod\n    def static(self) -> None:\n        pass\n"
              "    def ok(self, x: int) -> int:\n        return x\n"
              "    def _hidden(self, y):\n        pass\n"
              "class _Private:\n    def method(self, x):\n        pass\n")
    found = load_script("check_annotations").problems(source, "probe.py")
    assert found == ["probe.py:5: no_return lacks annotations for return",
                     "probe.py:7: no_param lacks annotations for a",
                     "probe.py:12: method lacks annotations for x",
                     "probe.py:15: static lacks annotations for self"], found
