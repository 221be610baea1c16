"""The size check (scripts/check_sizes.py, run by make lint): a module past 350 lines or a
function past 60 lines of code is listed in docs/development.md with why, and every
entry there is still past its limit."""

from __future__ import annotations

import os
import subprocess
import sys

from tests.shared import load_script

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "scripts", "check_sizes.py")


def test_the_package_keeps_the_size_rule():
    run = subprocess.run([sys.executable, SCRIPT], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:]


def test_a_long_module_or_function_not_listed_and_a_stale_entry_are_flagged():
    """Negative control: 351 lines unlisted, a 61-line function unlisted (its docstring not
    counted), and entries for a short module, a short function and a missing file."""
    check = load_script("check_sizes")
    body = "".join(f"    x{i} = {i}\n" for i in range(61))
    long_function = 'def f():\n    """Doc\n    string."""\n' + body
    files = {"a/long.py": "x = 1\n" * 351, "a/fn.py": long_function,
             "a/short.py": "x = 1\n", "a/doc.py": 'def g():\n    """' + "\n" * 70 + '"""\n    return 1\n'}
    page = ("- `a/short.py`: one concept\n- `a/short.py` `h`: a kernel\n- `a/gone.py`: moved\n")
    found = check.problems(files, page)
    assert any(p.startswith("a/long.py: 351 lines") for p in found), found
    assert any(p.startswith("a/fn.py: f has 61 lines") for p in found), found
    assert any("a/short.py: 1 lines, listed" in p for p in found), found
    assert any("a/short.py: h is listed" in p for p in found), found
    assert any(p.startswith("a/gone.py: listed") for p in found), found
    assert not any(p.startswith("a/doc.py") for p in found), found  # a long docstring is not code
    listed = "- `a/long.py`: one table\n- `a/fn.py` `f`: a kernel\n"
    assert check.problems({"a/long.py": files["a/long.py"], "a/fn.py": long_function}, listed) == []
