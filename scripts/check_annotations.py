"""The annotation check (``make lint``): every public function of the package, a
module-level ``def`` or a method of a public class whose name has no leading underscore,
annotates each parameter (``self`` and ``cls`` aside) and its return, so that mypy checks
its callers. Prints one line per function that does not (file:line: name, what is
missing) and exits 1 when there is one.
"""

from __future__ import annotations

import ast
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FOLDERS = ("infra", "scenes", "approx", "reference", "metrics", "experiment", "reports")


def missing(node: ast.FunctionDef | ast.AsyncFunctionDef, method: bool) -> list:
    """What ``node`` leaves unannotated: parameter names, and "return"."""
    args = node.args
    params = [*args.posonlyargs, *args.args, *args.kwonlyargs]
    if method and params and params[0].arg in ("self", "cls") and not any(
            isinstance(d, ast.Name) and d.id == "staticmethod" for d in node.decorator_list):
        params = params[1:]
    params += [a for a in (args.vararg, args.kwarg) if a is not None]
    out = [a.arg for a in params if a.annotation is None]
    return out + ([] if node.returns is not None else ["return"])


def public_functions(tree: ast.Module):
    """(node, is a method) of every public function of a module's tree."""
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not node.name.startswith("_"):
            yield node, False
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) and not item.name.startswith("_"):
                    yield item, True


def problems(source: str, label: str) -> list:
    return [f"{label}:{node.lineno}: {node.name} lacks annotations for {', '.join(gaps)}"
            for node, method in public_functions(ast.parse(source)) if (gaps := missing(node, method))]


def main() -> int:
    found = []
    for top in FOLDERS:
        for folder, dirs, files in os.walk(os.path.join(ROOT, top)):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            for name in sorted(files):
                if name.endswith(".py"):
                    path = os.path.join(folder, name)
                    with open(path, encoding="utf-8") as fh:
                        found += problems(fh.read(), os.path.relpath(path, ROOT))
    for line in found:
        print(line)
    print(f"check_annotations: {len(found)} public function(s) not fully annotated", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
