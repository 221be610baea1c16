"""DESIGN.md's one-way flow, scenes → approx | reference → metrics → reports, read
from the source with ``ast``: no package imports one above it or beside it."""

from __future__ import annotations

import ast
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FORBIDDEN = {
    "scenes": {"approx", "reference", "metrics", "reports"},  # the bottom of the flow
    "approx": {"reference", "metrics", "reports"},             # the renderers never import each other
    "reference": {"approx", "metrics", "reports"},
    "metrics": {"approx", "reference", "reports"},             # arrays and scenes formats only
}


def imported_packages(source: str, package: list[str]) -> dict:
    """Top-level package of every import in ``source`` (also inside functions;
    relative imports resolved against ``package``, the module's package path as
    parts) → first line number."""
    found = {}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            if node.module:
                names = [".".join(base + [node.module])]
            else:  # from . import x: the names are modules
                names = [".".join(base + [alias.name]) for alias in node.names]
        else:
            continue
        for name in names:
            found.setdefault(name.split(".")[0], node.lineno)
    return found


def modules(top: str):
    """(path, package parts) of every Python file of the top-level package ``top``."""
    for folder, _, files in os.walk(os.path.join(ROOT, top)):
        package = os.path.relpath(folder, ROOT).split(os.sep)
        for f in sorted(files):
            if f.endswith(".py"):
                yield os.path.join(folder, f), package


@pytest.mark.parametrize("top", sorted(FORBIDDEN))
def test_package_imports_follow_the_flow(top):
    wrong = []
    for path, package in modules(top):
        with open(path, encoding="utf-8") as fh:
            found = imported_packages(fh.read(), package)
        wrong += [f"{os.path.relpath(path, ROOT)}:{line} imports {name}"
                  for name, line in found.items() if name in FORBIDDEN[top]]
    assert not wrong, "\n".join(wrong)


def test_the_scan_sees_every_form_of_import():
    source = ("import numpy as np\n"
              "def f():\n"
              "    from approx.records import RECORD_DTYPE\n"  # deferred, inside a function
              "from . import cache\n"
              "from .. import metrics\n")
    found = imported_packages(source, ["reference"])
    assert found == {"numpy": 1, "approx": 3, "reference": 4, "metrics": 5}
