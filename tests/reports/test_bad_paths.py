"""Output paths, cache folders and special files: every command fails fast with exit 2
and a message naming the path, before it renders (issue 13, classes A, G, H, K, L)."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from reports.cli import main

ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False


def _fails_fast(capsys, argv, fragment, *, within=20.0):
    t0 = time.perf_counter()
    assert main(argv) == 2
    # nothing rendered: a render of the smallest built-in takes longer than this on any machine we know
    assert time.perf_counter() - t0 < within
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err
    return err


@pytest.mark.parametrize("output, fragment", [
    ("", "expected a file name ending in .exr"),
    ("sub/", "expected a file name ending in .exr"),
    ("out.png", "ending in .exr"),
    (".exr", "ending in .exr"),
    ("a_file/out.exr", "is not a folder"),
    ("a_folder.exr", "is a folder"),
    ("clash.exr", "is a folder"),           # its sibling clash.json is a folder
])
@pytest.mark.parametrize("command", ["approx", "reference"])
def test_bad_outputs_of_approx_and_reference(tmp_path, capsys, monkeypatch, command, output, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("x")
    (tmp_path / "a_folder.exr").mkdir()
    (tmp_path / "clash.json").mkdir()
    _fails_fast(capsys, [command, "sphere1", "-o", output], fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "a_folder.exr", "clash.json"]


def test_records_max_below_minus_one_is_refused(tmp_path, capsys):
    _fails_fast(capsys, ["approx", "sphere1", "-o", str(tmp_path / "o.exr"), "--records-max", "-5"],
                "--records-max")


@pytest.mark.parametrize("target, fragment", [
    ("a_file/scene.xml", "is not a folder"),
    ("scene.txt", "ending in .xml"),
    ("meshclash.xml", "is a file"),          # meshclash_meshes is a file
])
def test_bad_outputs_of_export(tmp_path, capsys, monkeypatch, target, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("x")
    (tmp_path / "meshclash_meshes").write_text("x")
    _fails_fast(capsys, ["export", "sphere1", "--mitsuba-xml", target], fragment)


@pytest.mark.skipif(ROOT, reason="root writes into read-only folders: the case cannot be made as root")
def test_a_read_only_output_folder(tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        _fails_fast(capsys, ["approx", "sphere1", "-o", str(folder / "o.exr")], "not a writable folder")
    finally:
        folder.chmod(0o755)


def test_a_cache_that_is_a_file_is_named_as_such(tmp_path, capsys, monkeypatch):
    """Not "an error in the scene's mesh": the cache folder, and the variable to fix."""
    cache = tmp_path / "cache"
    cache.write_text("not a folder")
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(cache))
    err = _fails_fast(capsys, ["scenes"], "cache folder")
    assert "VOLCAUSTICS_CACHE" in err and "could not be built" not in err and "specular" not in err


def test_a_mesh_path_that_is_a_device_or_fifo(tmp_path, write_scene):
    """/dev/zero was hashed forever and a FIFO blocked: both are refused at once (run in
    a subprocess with a timeout, so a regression fails instead of hanging the suite)."""
    fifo = tmp_path / "mesh.fifo"
    os.mkfifo(fifo)
    for mesh in ("/dev/zero", str(fifo)):
        text = open(write_scene()).read().replace('mesh = { generator = "sphere", radius = 0.5, subdivisions = 3 }',
                                                  f'mesh = "{mesh}"')
        scene = tmp_path / "special.toml"
        scene.write_text(text)
        done = subprocess.run([sys.executable, "-m", "reports.cli", "scenes", "--check", str(scene)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2, done.stderr
        assert "not a regular file" in done.stderr and "Traceback" not in done.stderr


def test_a_scene_file_that_is_a_fifo_or_nested_too_deeply(tmp_path):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    for path, fragment in ((fifo, "not a regular file"), (deep, "invalid TOML")):
        done = subprocess.run([sys.executable, "-m", "reports.cli", "scenes", "--check", str(path)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2, done.stderr
        assert fragment in done.stderr and "Traceback" not in done.stderr


def test_budgets_that_are_a_fifo(tmp_path, capsys):
    fifo = tmp_path / "budgets.toml"
    os.mkfifo(fifo)
    _fails_fast(capsys, ["gate", "--budgets", str(fifo), "--out", str(tmp_path / "g")], "not a regular file")
