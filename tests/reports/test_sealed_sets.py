"""Sealed sets (a study's output stored whole in the result store): written whole, read
back only when every hash matches, a damaged set replaced, and a copy refused by its
reader when a number, a file or the seal itself was changed."""

from __future__ import annotations

import json
import os

from volcaustics.reports.measuring.results.sealed_sets import complete_set, copy_set, damaged_set, write_set

KIND = "animation"


def _writer(value: int):
    def write(into: str) -> dict:
        with open(os.path.join(into, "table.csv"), "w") as fh:
            fh.write(f"x\n{value}\n")
        return {"kind": KIND, "value": value}
    return write


def test_a_set_is_written_whole_read_back_and_copied_byte_for_byte(tmp_path):
    folder = str(tmp_path / "animations" / "k1")
    doc = write_set(folder, "k1", KIND, _writer(1))
    assert complete_set(folder, "k1", KIND) == doc and doc["files"].keys() == {"table.csv"}
    assert complete_set(folder, "k2", KIND) is None and complete_set(folder, "k1", "comparison") is None
    paths = copy_set(folder, doc, str(tmp_path / "out"))
    assert open(paths["summary.json"], "rb").read() == open(os.path.join(folder, "summary.json"), "rb").read()
    assert damaged_set(str(tmp_path / "out"), doc) is None
    assert [n for n in os.listdir(tmp_path / "animations") if n.startswith(".tmp-")] == []


def test_a_damaged_set_is_measured_again_and_replaced(tmp_path):
    folder = str(tmp_path / "animations" / "k1")
    write_set(folder, "k1", KIND, _writer(1))
    with open(os.path.join(folder, "table.csv"), "a") as fh:
        fh.write("9\n")                                          # a file changed: the set is damaged
    assert complete_set(folder, "k1", KIND) is None
    doc = write_set(folder, "k1", KIND, _writer(2))              # measured again, put in its place
    assert doc["value"] == 2 and complete_set(folder, "k1", KIND) == doc
    assert sorted(os.listdir(tmp_path / "animations")) == ["k1"]  # the damaged copy set aside and removed


def test_an_edited_number_a_changed_file_and_a_removed_seal_are_named(tmp_path):
    """The reader's negative controls: each edit is named; an output from before sets had
    seals (no key, no files, no seal) is not refused."""
    folder = tmp_path / "set"
    doc = write_set(str(folder), "k1", KIND, _writer(1))
    summary = folder / "summary.json"
    edited = {**doc, "value": 3}
    summary.write_text(json.dumps(edited))
    assert damaged_set(str(folder), edited) == "its summary.json was edited after it was written"
    unsealed = {k: v for k, v in edited.items() if k != "summary_sha256"}
    assert damaged_set(str(folder), unsealed) == "its summary.json lost its seal"
    (folder / "table.csv").write_text("x\n7\n")
    assert damaged_set(str(folder), doc) == "table.csv is not the file it was written as"
    assert damaged_set(str(folder), {"kind": KIND, "value": 1}) is None


def test_another_writer_putting_its_set_in_place_meanwhile_wins_nothing_lost(tmp_path, monkeypatch):
    """Two processes replace one damaged set: the other one's complete set lands in the
    gap after this one set the damaged copy aside. This one keeps the other's (before:
    its rename failed with "Directory not empty" and the command exited 2)."""
    import shutil

    from volcaustics.reports.measuring.results import sealed_sets

    folder = str(tmp_path / "animations" / "k1")
    write_set(folder, "k1", KIND, _writer(1))
    theirs = str(tmp_path / "theirs")
    shutil.copytree(folder, theirs)                                  # the other process's complete set
    with open(os.path.join(folder, "table.csv"), "a") as fh:
        fh.write("9\n")                                              # the stored one damaged
    rename = os.rename

    def racing(src, dst):
        rename(src, dst)
        if ".damaged-" in str(dst) and not os.path.exists(folder):   # the damaged copy set aside: they land
            shutil.copytree(theirs, folder)

    monkeypatch.setattr(sealed_sets.os, "rename", racing)
    doc = write_set(folder, "k1", KIND, _writer(2))
    assert doc["value"] == 1 and complete_set(folder, "k1", KIND) == doc
    assert sorted(os.listdir(tmp_path / "animations")) == ["k1"]
