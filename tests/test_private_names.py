"""The private-name check (scripts/check_private_names.py, run by make lint): no module
imports or reaches another module's private name."""

from __future__ import annotations

import os

from tests.shared import load_script

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_no_module_uses_another_modules_private_name():
    checker = load_script("check_private_names")
    problems = [p for path in checker.scanned_files() for p in checker.check_file(path)]
    assert not problems, "\n".join(problems)


def test_a_private_name_crossing_a_module_boundary_is_flagged(tmp_path):
    """Negative control: each way of crossing is named; a library's private name, a
    public name and the module's own private name are not."""
    path = tmp_path / "crossing.py"
    path.write_text("import argparse, os\n"
                    "from volcaustics.scenes.toml_values import _REQUIRED, ranged\n"
                    "from .loader import _mesh_spec\n"
                    "from volcaustics.reports.measuring import runner\n"
                    "import volcaustics.metrics.flip\n"
                    "_mine = 1\n"
                    "runner._TOOLS, runner.TOOLS, os._exit, argparse._SubParsersAction, _mine, ranged\n"
                    "volcaustics.metrics\n", encoding="utf-8")
    found = load_script("check_private_names").check_file(str(path))
    assert len(found) == 3, found
    for name in ("imports _REQUIRED from volcaustics.scenes.toml_values", "imports _mesh_spec from .loader",
                 "reaches runner._TOOLS"):
        assert any(name in line for line in found), (name, found)
