"""Code versions: a hash of what the sources under whole folders do, so that the boundary
of what changes a cached result is visible in the layout (a file moved within a folder
or added to it changes the hash; code outside the folders never does).

A Python file enters as its syntax tree without docstrings (``ast``: comments and
layout are not in it), a GLSL file as its lines without comments and surrounding
blanks: a documentation edit keeps every stored result, any change of a statement, a
constant or a name re-keys them. The tree's form is the interpreter's: a result keyed
under one Python minor version is measured again under another.
"""

from __future__ import annotations

import ast
import hashlib
import os
import re
from functools import lru_cache

SOURCE_SUFFIXES = (".py", ".glsl")
_GLSL_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.DOTALL)


@lru_cache(maxsize=None)
def folder_files(folder: str) -> tuple:
    files: list[str] = []
    for parent, dirs, names in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        files.extend(os.path.join(parent, n) for n in names if n.endswith(SOURCE_SUFFIXES))
    return tuple(sorted(files))


def python_code(text: str) -> bytes:
    """What a Python source does: its syntax tree without docstrings (module, class and
    function), dumped without line numbers; the bytes themselves when it does not parse
    (a broken file still changes the hash)."""
    try:
        tree = ast.parse(text)
    except SyntaxError:
        return text.encode()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree, annotate_fields=False, include_attributes=False).encode()


def glsl_code(text: str) -> bytes:
    """What a GLSL source does: its lines without ``//`` and ``/* */`` comments, leading
    and trailing blanks and empty lines (line breaks kept: they end a preprocessor
    directive)."""
    lines = (line.strip() for line in _GLSL_COMMENT.sub(" ", text).splitlines())
    return "\n".join(line for line in lines if line).encode()


def source_code(path: str) -> bytes:
    """The hashed form of the source file at ``path`` (:func:`python_code`,
    :func:`glsl_code`); the file is read each time, its form kept per text."""
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    return _code_of(text, path.endswith(".py"))


@lru_cache(maxsize=1024)
def _code_of(text: str, python: bool) -> bytes:
    # a process hashes its folders several times (each cache's code version, each point's
    # key): parsing every file again each time took 0.1-0.2 s
    return python_code(text) if python else glsl_code(text)


def source_hash(folders: dict) -> str:
    """SHA-256 (16 hex digits) of the Python and GLSL code under each folder.

    ``folders`` maps a label (the folder as the repository names it, e.g.
    ``"reference/render"``) to its path; each file enters as its label-relative name
    and its code (:func:`source_code`), in sorted order, so the hash does not depend on
    where the package is installed nor on its comments and docstrings."""
    h = hashlib.sha256()
    for label in sorted(folders):
        root = folders[label]
        for path in folder_files(root):
            h.update(f"{label}/{os.path.relpath(path, root)}".replace(os.sep, "/").encode())
            code = source_code(path)
            h.update(len(code).to_bytes(8, "little"))  # file boundaries cannot shift between files
            h.update(code)
    return h.hexdigest()[:16]
