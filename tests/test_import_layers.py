"""The layers of docs/architecture.md, read from that page and checked against the source
with ``ast``: no module imports a layer above its own or a sibling on its own layer (between
the top-level folders, and between the subpackages of ``reports``), no import cycle exists
anywhere (imports inside functions and type-only ones count), and every import is spelled in the installed
namespace (``volcaustics.<folder>``), never by a bare folder name."""

from __future__ import annotations

import ast
import os
import re

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ARCHITECTURE = os.path.join(ROOT, "docs", "architecture.md")


def read_layers(text: str) -> dict:
    """``{"packages": [[names of level 0], [level 1], ...], "reports": [...]}`` from the page's
    ``packages: a < b | c < d`` lines (``<``: the level above; ``|``: siblings)."""
    layers = {}
    for kind, order in re.findall(r"^(packages|reports): (.+)$", text, flags=re.M):
        layers[kind] = [[name.strip() for name in level.split("|")] for level in order.split("<")]
    return layers


with open(ARCHITECTURE, encoding="utf-8") as _fh:
    LAYERS = read_layers(_fh.read())
FOLDERS = tuple(name for level in LAYERS["packages"] for name in level)
REPORTS_LEVELS = tuple(tuple(level) for level in LAYERS["reports"])


def imported_modules(source: str, package: list[str]) -> dict:
    """Every imported module in ``source`` (also inside functions; relative imports
    resolved against ``package``, the module's package path as parts) → first line."""
    found = {}
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            if node.module:
                module = ".".join(base + [node.module])
                names = [module]
                if module.count(".") < 2:  # from volcaustics.reports.measuring import runner: the names are modules
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


def _package_level(name: str) -> int | None:
    for i, names in enumerate(LAYERS["packages"]):
        if name in names:
            return i
    return None


@pytest.mark.parametrize("top", FOLDERS)
def test_package_imports_follow_the_layers(top):
    mine = _package_level(top)
    wrong = []
    for path, package in modules(top):
        for name, line in _imports(path, package).items():
            target = project_part(name)
            if target is None or target == top or target not in FOLDERS:
                continue
            if _package_level(target) >= mine:
                wrong.append(f"{os.path.relpath(path, ROOT)}:{line} imports {name} (layer {target})")
    assert not wrong, "\n".join(wrong)


ROOMS = tuple(name for level in REPORTS_LEVELS for name in level)


def _level(room: str | None) -> int | None:
    for i, names in enumerate(REPORTS_LEVELS):
        if room in names:
            return i
    return None


def room_of(name: str) -> str | None:
    """The room of the layer line that module ``name`` (``volcaustics.reports.…``) is in:
    the longest room (``measuring.results``, ``cli``) its dotted path starts with."""
    parts = name.split(".")[2:]
    for depth in range(len(parts), 0, -1):
        if ".".join(parts[:depth]) in ROOMS:
            return ".".join(parts[:depth])
    return None


def test_reports_rooms_import_downwards():
    wrong = []
    for path, package in modules("reports"):
        stem = os.path.splitext(os.path.basename(path))[0]
        if len(package) == 2 or (stem == "__init__" and ".".join(package[2:]) not in ROOMS
                                 and room_of(".".join(package)) is None):
            continue  # reports/__init__.py and a group's own __init__ (measuring, studies, presenting)
        own = room_of(".".join([*package, stem]))
        assert own is not None, f"{path}: in no room of REPORTS_LEVELS"
        mine = _level(own)
        for name, line in _imports(path, package).items():
            if project_part(name) != "reports" or name == "volcaustics.reports":
                continue
            theirs = room_of(name)
            if theirs is None and name.count(".") == 2:  # a group package itself (a docstring)
                continue
            if theirs != own and (theirs is None or (level := _level(theirs)) is None or mine is None
                                  or level >= mine):
                wrong.append(f"{os.path.relpath(path, ROOT)}:{line} ({own}) imports {name}")
    assert not wrong, "\n".join(wrong)


def test_no_two_modules_of_reports_share_a_name():
    """A module's name says what it is wherever it is read (a traceback, an import): no
    two modules of reports/ share one (before: run.py six times, write.py four)."""
    seen: dict = {}
    for path, _ in modules("reports"):
        name = os.path.basename(path)
        if name not in ("__init__.py", "__main__.py"):
            seen.setdefault(name, []).append(os.path.relpath(path, ROOT))
    assert not {n: p for n, p in seen.items() if len(p) > 1}


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


def test_the_page_states_every_folder_and_room():
    """Every top-level package folder and every room of reports (a subpackage, or a loose
    module of a group folder) is on the page, and nothing else."""
    on_disk = {d for d in os.listdir(ROOT) if os.path.isfile(os.path.join(ROOT, d, "__init__.py"))}
    on_disk -= {"tests", "package"}
    assert on_disk == set(FOLDERS), sorted(on_disk ^ set(FOLDERS))
    rooms = set()
    top = os.path.join(ROOT, "reports")
    for entry in os.listdir(top):
        if entry.endswith(".py") and entry != "__init__.py":
            rooms.add(entry[:-3])
        elif entry in ROOMS:
            rooms.add(entry)
        elif os.path.isfile(os.path.join(top, entry, "__init__.py")):  # a group: its subpackages and modules
            for sub in os.listdir(os.path.join(top, entry)):
                if sub.endswith(".py") and sub != "__init__.py":
                    rooms.add(f"{entry}.{sub[:-3]}")
                elif os.path.isfile(os.path.join(top, entry, sub, "__init__.py")):
                    rooms.add(f"{entry}.{sub}")
    assert rooms == set(ROOMS), sorted(rooms ^ set(ROOMS))


def module_graph() -> dict:
    """Module → the project modules it imports (explicitly; inside functions and under
    ``if TYPE_CHECKING:`` too)."""
    files = {}
    for top in FOLDERS:
        for path, package in modules(top):
            stem = os.path.splitext(os.path.basename(path))[0]
            name = ".".join(package) if stem == "__init__" else ".".join([*package, stem])
            files[name] = (path, package)
    graph = {}
    for name, (path, package) in files.items():
        targets = set()
        for imported in _imports(path, package):
            if imported in files:
                targets.add(imported)
            elif imported.rpartition(".")[0] in files:  # from package import attribute
                targets.add(imported.rpartition(".")[0])
        graph[name] = targets - {name}
    return graph


def cycles(graph: dict) -> list:
    """The strongly connected components with more than one module (Tarjan), sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def test_no_import_cycles():
    """Not even through a type-only import: a module that needs another's types while
    that one calls it back is one concept in two files, or a type in the wrong one (the
    scene model and its canonical JSON, the gate's result and its writer were)."""
    found = cycles(module_graph())
    assert not found, "\n".join(" <-> ".join(c) for c in found)


def test_the_cycle_check_finds_a_cycle():
    """Negative control: a two-module and a three-module cycle are found, a chain is not."""
    graph = {"a": {"b"}, "b": {"a"}, "c": {"d"}, "d": {"e"}, "e": {"c"}, "f": {"g"}, "g": set()}
    assert cycles(graph) == [["a", "b"], ["c", "d", "e"]]


def test_the_page_is_read_as_written():
    text = "packages: infra < scenes < approx | reference < reports\nreports: core < files | runner < cli\n"
    assert read_layers(text) == {"packages": [["infra"], ["scenes"], ["approx", "reference"], ["reports"]],
                                 "reports": [["core"], ["files", "runner"], ["cli"]]}
