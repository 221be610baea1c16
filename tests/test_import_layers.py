"""docs/architecture.md's layers, read from the source with ``ast``: between the packages,
scenes → approx | reference → metrics → reports; inside ``reports``, its subpackages
core ← {experiment, render} ← runner ← {animate, compare} ← gate ← sweep ← page ← cli (the page shows the
gate's verdicts and a sweep's figures). No module imports
one above it or beside it, and every import is spelled in the installed namespace
(``volcaustics.<folder>``), never by a bare folder name."""

from __future__ import annotations

import ast
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FOLDERS = ("scenes", "approx", "reference", "metrics", "reports")
FORBIDDEN = {
    "scenes": {"approx", "reference", "metrics", "reports"},  # the bottom of the flow
    "approx": {"reference", "metrics", "reports"},             # the renderers never import each other
    "reference": {"approx", "metrics", "reports"},
    "metrics": {"approx", "reference", "reports"},             # arrays and scenes formats only
}
# reports' subpackages by level: a module may import its own level's subpackage and lower levels
REPORTS_LEVELS = (("core",), ("experiment", "render"), ("runner",), ("animate", "compare"), ("gate",), ("sweep",),
                  ("page",), ("cli",))


def imported_modules(source: str, package: list[str]) -> dict:
    """Every imported module in ``source`` (also inside functions; relative imports
    resolved against ``package``, the module's package path as parts) → first line."""
    found = {}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            if node.module:
                module = ".".join(base + [node.module])
                names = [module]
                if module.count(".") < 2:  # from volcaustics.reports import runner: the names are modules
                    names += [f"{module}.{alias.name}" for alias in node.names]
            else:  # from . import x: the names are modules
                names = [".".join(base + [alias.name]) for alias in node.names]
        else:
            continue
        for name in names:
            found.setdefault(name, node.lineno)
    return found


def project_part(name: str, depth: int = 1) -> str | None:
    """The folder (``depth`` 1) or subfolder (2) of the project that ``name`` imports,
    None for another distribution."""
    parts = name.split(".")
    if parts[0] != "volcaustics" or len(parts) < 2:
        return None
    return ".".join(parts[1:1 + depth])


def modules(top: str):
    """(path, package parts in the installed namespace) of every file of folder ``top``."""
    for folder, _, files in os.walk(os.path.join(ROOT, top)):
        package = ["volcaustics", *os.path.relpath(folder, ROOT).split(os.sep)]
        for f in sorted(files):
            if f.endswith(".py"):
                yield os.path.join(folder, f), package


def _imports(path, package) -> dict:
    with open(path, encoding="utf-8") as fh:
        return imported_modules(fh.read(), package)


@pytest.mark.parametrize("top", sorted(FORBIDDEN))
def test_package_imports_follow_the_flow(top):
    wrong = []
    for path, package in modules(top):
        wrong += [f"{os.path.relpath(path, ROOT)}:{line} imports {name}"
                  for name, line in _imports(path, package).items() if project_part(name) in FORBIDDEN[top]]
    assert not wrong, "\n".join(wrong)


def _level(sub: str) -> int | None:
    for i, names in enumerate(REPORTS_LEVELS):
        if sub in names:
            return i
    return None


def test_reports_subpackages_import_downwards():
    wrong = []
    for path, package in modules("reports"):
        own = package[2] if len(package) > 2 else os.path.splitext(os.path.basename(path))[0]
        mine = _level(own)
        assert mine is not None or own == "__init__", f"{path}: {own} is not in REPORTS_LEVELS"
        for name, line in _imports(path, package).items():
            if project_part(name) != "reports":
                continue
            if name == "volcaustics.reports":  # the package itself (a docstring): `from volcaustics.reports import x`
                continue
            target = name.split(".")[2]
            theirs = _level(target)
            if target != own and (theirs is None or mine is None or theirs >= mine):
                wrong.append(f"{os.path.relpath(path, ROOT)}:{line} ({own}) imports {name}")
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("top", [*FOLDERS, "tests", "bench"])
def test_imports_use_the_installed_namespace(top):
    bare = []
    for path, package in modules(top):
        bare += [f"{os.path.relpath(path, ROOT)}:{line} imports {name}"
                 for name, line in _imports(path, package).items() if name.split(".")[0] in FOLDERS]
    assert not bare, "\n".join(bare)


def test_the_scan_sees_every_form_of_import():
    source = ("import numpy as np\n"
              "def f():\n"
              "    from volcaustics.approx.records import RECORD_DTYPE\n"  # deferred, inside a function
              "from . import cache\n"
              "from .. import metrics\n")
    found = imported_modules(source, ["volcaustics", "reference"])
    assert found == {"numpy": 1, "volcaustics.approx.records": 3, "volcaustics.reference.cache": 4,
                     "volcaustics.metrics": 5}
    assert {n: project_part(n) for n in found} == {"numpy": None, "volcaustics.approx.records": "approx",
                                                   "volcaustics.reference.cache": "reference",
                                                   "volcaustics.metrics": "metrics"}
