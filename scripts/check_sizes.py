"""The size check (``make lint``): the rule ``docs/development.md`` states under "Size".
A module past 350 lines must be listed there with why it is one concept (the question
was asked and answered), and a function past 60 lines of code (its docstring not
counted) must be listed there as an exception; a listed module or function that no
longer is past its limit (or no longer exists) is a stale entry. Prints one line per
problem and exits 1 when there is one.
"""

from __future__ import annotations

import ast
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FOLDERS = ("infra", "scenes", "approx", "reference", "metrics", "experiment", "reports", "package")
PAGE = os.path.join(ROOT, "docs", "development.md")
MODULE_LINES = 350
FUNCTION_LINES = 60
# an entry of the page's lists: "- `path/to/module.py`: why" or "- `path.py` `Class.function`: why"
ENTRY = re.compile(r"^- `([\w/]+\.py)`(?: `([\w.]+)`)?: \S", flags=re.M)


def listed(text: str) -> tuple[set, set]:
    """(modules, (module, function) pairs) the page lists as past their limits."""
    modules, functions = set(), set()
    for path, function in ENTRY.findall(text):
        (functions.add((path, function)) if function else modules.add(path))
    return modules, functions


def _code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    first = node.body[0]
    docstring = isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
        and isinstance(first.value.value, str)
    start = first.end_lineno + 1 if docstring and len(node.body) > 1 else node.lineno
    return (node.end_lineno or start) - start + 1


def long_functions(source: str) -> dict:
    """Qualified name (``Class.method``, ``function``) → code lines, of every function of
    ``source`` past FUNCTION_LINES (nested ones named inside their parent)."""
    found = {}

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef) and _code_lines(child) > FUNCTION_LINES:
                    found[name] = _code_lines(child)
                visit(child, f"{name}.")

    visit(ast.parse(source), "")
    return found


def problems(files: dict, page: str) -> list:
    """``files``: path (relative to the root) → source."""
    modules, functions = listed(page)
    out = []
    for path, source in sorted(files.items()):
        lines = source.count("\n")
        if lines > MODULE_LINES and path not in modules:
            out.append(f"{path}: {lines} lines (> {MODULE_LINES}): does it hold two concepts? Split it where "
                       f"it does; else list it in docs/development.md \"Size\" saying why it is one")
        if lines <= MODULE_LINES and path in modules:
            out.append(f"{path}: {lines} lines, listed in docs/development.md as past {MODULE_LINES}: remove the entry")
        for name, count in long_functions(source).items():
            if (path, name) not in functions:
                out.append(f"{path}: {name} has {count} lines of code (> {FUNCTION_LINES})")
        for _, name in sorted(f for f in functions if f[0] == path):
            if name not in long_functions(source):
                out.append(f"{path}: {name} is listed in docs/development.md as past {FUNCTION_LINES} lines and "
                           f"is not: remove the entry")
    out += [f"{path}: listed in docs/development.md and not a module of the package"
            for path in sorted(modules | {p for p, _ in functions}) if path not in files]
    return out


def main() -> int:
    files = {}
    for top in FOLDERS:
        for folder, dirs, names in os.walk(os.path.join(ROOT, top)):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            for name in sorted(names):
                if name.endswith(".py"):
                    path = os.path.join(folder, name)
                    with open(path, encoding="utf-8") as fh:
                        files[os.path.relpath(path, ROOT)] = fh.read()
    with open(PAGE, encoding="utf-8") as fh:
        found = problems(files, fh.read())
    for line in found:
        print(line)
    print(f"check_sizes: {len(found)} problem(s) with the size rule", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
