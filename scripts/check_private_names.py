"""The private-name check (``make lint`` and a test): a name that starts with one
underscore belongs to its module. No module of the package, its tests, benches or
scripts may import another module's private name (``from <module> import _y``, also
relative) or reach it through the module (``module._y``, the module imported from
this project). A helper two modules need gets a public name in a module of
its own. Other libraries' private names (``argparse._SubParsersAction``, ``os._exit``)
are theirs to keep and not checked.

Prints one line per crossing (file:line: what) and exits 1 when there is one.
"""

from __future__ import annotations

import ast
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TREES = ("infra", "scenes", "approx", "reference", "metrics", "experiment", "reports", "tests", "bench", "scripts")
OWN = ("volcaustics", "tests", *TREES)  # the first part of a module name of this project


def scanned_files() -> list:
    """Every Python file of the trees above."""
    out = []
    for tree in TREES:
        for folder, dirs, files in os.walk(os.path.join(ROOT, tree)):
            dirs[:] = [d for d in dirs if d != "__pycache__"]
            out += [os.path.join(folder, f) for f in sorted(files) if f.endswith(".py")]
    return out


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _own(node: ast.ImportFrom) -> bool:
    return node.level > 0 or (node.module or "").split(".")[0] in OWN


def check_file(path: str) -> list:
    """One line per private name of another module that ``path`` imports or reaches."""
    with open(path, encoding="utf-8") as fh:
        tree = ast.parse(fh.read(), filename=path)
    where = os.path.relpath(path, ROOT)
    problems, modules = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules |= {(a.asname or a.name).split(".")[0] for a in node.names if a.name.split(".")[0] in OWN}
        elif isinstance(node, ast.ImportFrom) and _own(node):
            module = "." * node.level + (node.module or "")
            for alias in node.names:
                if _private(alias.name):
                    problems.append(f"{where}:{node.lineno}: imports {alias.name} from {module}: a private name "
                                    f"of another module (give it a public name in a module of its own)")
                else:
                    modules.add(alias.asname or alias.name)  # a module or a public name: either may be a module
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and _private(node.attr) and isinstance(node.value, ast.Name)
                and node.value.id in modules):
            problems.append(f"{where}:{node.lineno}: reaches {node.value.id}.{node.attr}: a private name of "
                            f"another module (give it a public name)")
    return problems


def main() -> int:
    problems = [p for path in scanned_files() for p in check_file(path)]
    for line in problems:
        print(line)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
