"""The reference check (``make docs``, ``make lint`` and a test): every file path, dotted
module name and ``docs/…`` section named in the code, tests, README and docs must exist,
and nothing may point at a tracker or a document outside the repository.

Prints one line per stale reference (file:line: what, why) and exits 1 when there is one.
"""

from __future__ import annotations

import ast
import glob
import io
import os
import re
import sys
import tokenize

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FOLDERS = ("infra", "scenes", "approx", "reference", "metrics", "experiment", "reports")
TREES = (*FOLDERS, "tests", "bench", "scripts", "docs", "volcaustics", ".ci")
TOP_FILES = ("README.md", "Makefile", "pyproject.toml", "setup.py", "mkdocs.yml")
SCANNED = (".py", ".md", ".toml", ".sh", ".glsl", ".yml", ".cfg")
SKIP_DIRS = {"__pycache__", "node_modules", "img"}

PATH = re.compile(r"(?<![\w./$-])((?:%s)/[\w./*<>{}-]*[\w/*])" % "|".join(re.escape(t) for t in TREES))
# a dotted name: spelled volcaustics.<folder>.… anywhere, or a bare <folder>.… in backticks (in code, a bare
# reference.mean is a variable's attribute)
DOTTED = re.compile(r"(?:(?<![\w./-])(volcaustics(?:\.[A-Za-z_]\w*)+)|(?<=`)((?:%s)(?:\.[A-Za-z_]\w*)+))(?![\w/-])"
                    % "|".join(FOLDERS))
ANCHOR = re.compile(r"(docs/[\w/-]+\.md)`?\s*(?:\(|,)?\s*\"([^\"]+)\"")
LINK_ANCHOR = re.compile(r"(docs/[\w/-]+\.md)#([\w-]+)")
MD_LINK = re.compile(r"\]\(([^)#\s]+\.md)(?:#([\w-]+))?\)")
TRACKER = re.compile(r"\b[Ii]ssues? (?:#?\d+|\")|\b(?:DESIGN|STYLE)\.md\b")  # a tracker's issue, by number or title
FILE_EXT = re.compile(r"\.(py|toml|md|sh|glsl|json|csv|parquet|png|svg|exr|yml|txt|ply|npz|html|xml|glb|gltf|webp"
                      r"|mp4)$")


def scanned_files():
    for top in TREES:
        for folder, dirs, files in os.walk(os.path.join(ROOT, top)):
            dirs[:] = [d for d in dirs if d not in SKIP_DIRS]
            for name in sorted(files):
                if name.endswith(SCANNED):
                    yield os.path.join(folder, name)
    for name in TOP_FILES:
        yield os.path.join(ROOT, name)


def _path_exists(path: str) -> bool:
    path = path.rstrip(".")
    if re.search(r"[<>{}]|\b[A-Z]{2,}\b", path):  # a placeholder (OUT, NAME, <pass>): check the part before it
        path = re.split(r"[<>{}]|\b[A-Z]{2,}\b", path)[0]
        return bool(glob.glob(os.path.join(ROOT, path.rsplit("/", 1)[0] if "/" in path else path) + "*"))
    return bool(glob.glob(os.path.join(ROOT, path)))


def _module_file(parts: list) -> str | None:
    folder = os.path.join(ROOT, *parts)
    if os.path.isfile(folder + ".py"):
        return folder + ".py"
    if os.path.isfile(os.path.join(folder, "__init__.py")):
        return os.path.join(folder, "__init__.py")
    return None


def _names_defined(path: str) -> set:
    with open(path, encoding="utf-8") as fh:
        tree = ast.parse(fh.read())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                names |= {n.id for n in ast.walk(target) if isinstance(n, ast.Name)}
                names |= {n.attr for n in ast.walk(target) if isinstance(n, ast.Attribute)}
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
    return names


def dotted_resolves(name: str) -> bool:
    """``volcaustics.reports.measuring.results.param_input.PARAMS`` or ``approx.trace.read_raw_records``:
    the longest prefix that is a module, the rest names defined in it (or its folder)."""
    parts = name.split(".")
    if parts[0] == "volcaustics":
        parts = parts[1:]
    for cut in range(len(parts), 0, -1):
        path = _module_file(parts[:cut])
        if path:
            rest = parts[cut:]
            if not rest:
                return True
            if rest[0] in _names_defined(path):
                return True
            return _module_file(parts[:cut] + rest[:1]) is not None
    return False


def _headings(path: str) -> tuple:
    """(titles, slugs) of a Markdown file's headings, as MkDocs' toc makes them."""
    titles, slugs = set(), set()
    with open(path, encoding="utf-8") as fh:
        inside = False
        for line in fh:
            if line.startswith("```"):
                inside = not inside
            if inside or not line.startswith("#"):
                continue
            title = line.lstrip("#").strip()
            titles.add(title)
            plain = re.sub(r"[`*_]", "", title).lower()
            slugs.add(re.sub(r"[\s]+", "-", re.sub(r"[^\w\s-]", "", plain)).strip("-"))
    return titles, slugs


def _anchor_ok(doc: str, title: str, slug: bool) -> bool:
    path = os.path.join(ROOT, doc)
    if not os.path.isfile(path):
        return False
    titles, slugs = _headings(path)
    if slug:
        return title in slugs
    title = " ".join(title.split())
    return any(t == title or t.startswith(title) for t in titles)


def prose(source: str) -> str:
    """A Python file's comments and docstrings, at their own lines (everything else blank):
    a string literal in code may be test data or a path inside a wheel."""
    lines = [""] * (source.count("\n") + 1)
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            lines[token.start[0] - 1] += token.string
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            value = first.value if isinstance(first, ast.Expr) else None
            if isinstance(value, ast.Constant) and isinstance(value.value, str):
                for i, line in enumerate(value.value.split("\n")):
                    lines[first.lineno - 1 + i] += " " + line
    return "\n".join(lines)


def check_file(path: str) -> list:
    rel = os.path.relpath(path, ROOT)
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    raw = text
    if path.endswith(".py"):
        text = prose(text)
    # a comment or docstring wraps long references: join continuation lines for the anchor search
    joined = re.sub(r"\n\s*(?:#|//)?\s*", " ", text)
    problems = []

    def line_of(fragment: str) -> int:
        at = text.find(fragment.split()[0]) if fragment.split() else -1
        return text.count("\n", 0, at) + 1 if at >= 0 else 0

    for mo in TRACKER.finditer(raw):
        outside = f"{mo.group(0)!r}: names something outside the repository"
        problems.append((raw.count("\n", 0, mo.start()) + 1, outside))
    for mo in PATH.finditer(text):
        if not _path_exists(mo.group(1)):
            problems.append((text.count("\n", 0, mo.start()) + 1, f"path {mo.group(1)} does not exist"))
    for mo in DOTTED.finditer(text):
        name = mo.group(1) or mo.group(2)
        if FILE_EXT.search(name):
            continue
        if not dotted_resolves(name):
            problems.append((text.count("\n", 0, mo.start()) + 1, f"module name {name} does not resolve"))
    for mo in ANCHOR.finditer(joined):
        if not _anchor_ok(mo.group(1), mo.group(2), slug=False):
            problems.append((line_of(mo.group(2)), f'{mo.group(1)} "{mo.group(2)}": no such section'))
    for mo in LINK_ANCHOR.finditer(text):
        if not _anchor_ok(mo.group(1), mo.group(2), slug=True):
            problems.append((text.count("\n", 0, mo.start()) + 1, f"{mo.group(1)}#{mo.group(2)}: no such section"))
    if path.endswith(".md"):
        for mo in MD_LINK.finditer(text):
            target = os.path.normpath(os.path.join(os.path.dirname(rel), mo.group(1)))
            if mo.group(1).startswith("http"):
                continue
            if mo.group(2):
                ok = _anchor_ok(target, mo.group(2), slug=True)
            else:
                ok = os.path.isfile(os.path.join(ROOT, target))
            if not ok:
                problems.append((text.count("\n", 0, mo.start()) + 1, f"link {mo.group(0)[2:-1]}: target missing"))
    return [f"{rel}:{line}: {what}" for line, what in problems]


def main() -> int:
    problems = [p for path in scanned_files() if os.path.isfile(path) for p in check_file(path)]
    for problem in problems:
        print(problem)
    print(f"check_references: {len(problems)} stale reference(s)", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
