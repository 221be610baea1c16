"""The reference check (scripts/check_references.py, run by make lint and make docs): every
file path, dotted module name and docs section named in the repository exists, and nothing
points at a tracker or a document outside it."""

from __future__ import annotations

import os

from tests.shared import load_script

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_every_reference_in_the_repository_resolves():
    checker = load_script("check_references")
    problems = [p for path in checker.scanned_files() if os.path.isfile(path) for p in checker.check_file(path)]
    assert not problems, "\n".join(problems)


def test_stale_references_are_flagged(tmp_path):
    """Negative control: one of each kind of stale reference, each named."""
    checker = load_script("check_references")
    path = tmp_path / "stale.md"
    tracker, outside = "iss" + "ue 12", "DESI" + "GN.md"  # spelled apart: this file is checked too
    titled = "iss" + 'ue "Fast answers"'
    path.write_text(f"See `reports/no_such_module.py`, `volcaustics.approx.no_such_name`, the fix of {tracker},\n"
                    f"{titled}, {outside}, docs/decisions.md \"No such section\" and [a link](no_such_page.md).\n"
                    "These exist: `approx/params.py`, `volcaustics.approx.params.PARAMS`, docs/decisions.md \"Start"
                    " offset\".\n", encoding="utf-8")
    found = "\n".join(checker.check_file(str(path)))
    for stale in ("reports/no_such_module.py", "volcaustics.approx.no_such_name", tracker, titled[:7], outside,
                  "No such section", "no_such_page.md"):
        assert stale in found, (stale, found)
    assert "approx/params.py" not in found and "params.PARAMS" not in found and "Start offset" not in found
    assert len(found.splitlines()) == 7, found
