"""Result keys come from what the code does (``infra.sources``): a copy of ``approx/``
keeps its hash through docstring, comment and layout edits in Python and GLSL, and
changes it for any change of a statement (the negative controls: a constant, a GLSL
value, a file added)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from volcaustics.infra import sources

APPROX = Path(__file__).resolve().parents[2] / "approx"


@pytest.fixture
def folder(tmp_path):
    """A fresh copy of approx/ and a function giving its hash now."""
    copy = tmp_path / "approx"
    shutil.copytree(APPROX, copy, ignore=shutil.ignore_patterns("__pycache__"))

    def hashed() -> str:
        sources.folder_files.cache_clear()
        return sources.source_hash({"approx": str(copy)})
    return copy, hashed


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text, f"{path.name} no longer holds {old!r}: update the test's edit"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")


def test_documentation_edits_keep_the_hash(folder):
    copy, hashed = folder
    before = hashed()
    _edit(copy / "cost.py",
          '"""A frame\'s cost that travels', '"""A frame\'s cost (reworded) that travels')    # module docstring
    _edit(copy / "cost.py", "    \"\"\"One frame's cost", "    \"\"\"One frame's whole cost")  # function docstring
    _edit(copy / "cost.py", "DENSITY_READS = 5\n", "# a comment of its own line\nDENSITY_READS  =  5  # spaced\n")
    _edit(copy / "shaders" / "splat" / "kernel.glsl", "// Truncation of the splat kernel",
          "/* reworded */   // Truncation of a splat kernel")
    _edit(copy / "shaders" / "splat" / "kernel.glsl", "const float TRUNCATION = 3.0;",
          "   const float TRUNCATION = 3.0;   ")
    assert hashed() == before


@pytest.mark.parametrize("where, old, new", [
    ("cost.py", "DENSITY_READS = 5\n", "DENSITY_READS = 6\n"),                   # a constant
    ("cost.py", "DENSITY_READS = 5\n", "DENSITY_READS = 5\nEXTRA = 1\n"),        # a statement added
    ("shaders/splat/kernel.glsl", "const float TRUNCATION = 3.0;", "const float TRUNCATION = 3.5;"),
])
def test_a_change_of_code_changes_the_hash(folder, where, old, new):
    copy, hashed = folder
    before = hashed()
    _edit(copy / where, old, new)
    assert hashed() != before


def test_a_file_added_or_one_that_does_not_parse_changes_the_hash(folder):
    copy, hashed = folder
    before = hashed()
    (copy / "extra.py").write_text("def broken(:\n", encoding="utf-8")
    broken = hashed()
    assert broken != before
    (copy / "extra.py").write_text("def broken(: \n", encoding="utf-8")  # unparsable: its bytes count
    assert hashed() != broken


def test_every_folder_a_key_hashes_exists_and_a_missing_one_is_an_error():
    """A folder moved away would hash nothing, leaving a key blind to its code (the page
    pictures' key named a folder after it had moved): every folder the result and page
    keys name exists, and a missing one raises (the negative control)."""
    from volcaustics.experiment.versions import EXPERIMENT_FOLDERS, code_version
    from volcaustics.reports.presenting.page.page_write import PAGE_FOLDERS

    assert len(code_version(EXPERIMENT_FOLDERS)) == 16 and len(code_version(PAGE_FOLDERS)) == 16
    with pytest.raises(FileNotFoundError, match="reports/MOVED"):
        code_version(("reports/presenting/page", "reports/MOVED"))
