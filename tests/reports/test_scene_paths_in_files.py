"""One rule for scene files named in a file: a relative path is relative to
the file that names it — a sweep spec's ``scenes``, a budgets file's ``[scene."…"]`` —
as a scene file's mesh paths are to it; on the command line, to the working directory.
Budgets resolved them against the working directory before."""

from __future__ import annotations

import os

import pytest

from tests.shared import BASE_SCENE
from volcaustics.reports.cli import main
from volcaustics.reports.studies.gate.budgets import load_budgets
from volcaustics.reports.studies.sweep.sweep_spec import spec_from_toml
from volcaustics.scenes import resolve_scene

BUDGETS = """
preset = "quick"
seeds = 2
[scene."scenes/mine.toml"]
caustic = { relmse_max = 0.6 }
[scene.bunny]
caustic = { relmse_max = 0.6 }
"""
SPEC = """
scenes = ["scenes/mine.toml", "bunny"]
[vary]
layers = [1, 2]
"""


@pytest.fixture
def files(tmp_path, monkeypatch):
    """A budgets file and a sweep spec in tmp/config/, the scene in tmp/config/scenes/,
    and the working directory elsewhere (tmp/work/)."""
    config = tmp_path / "config"
    (config / "scenes").mkdir(parents=True)
    (config / "scenes" / "mine.toml").write_text(BASE_SCENE)
    (config / "budgets.toml").write_text(BUDGETS)
    (config / "sweep.toml").write_text(SPEC)
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    return config


def test_budgets_and_sweep_specs_resolve_scenes_against_their_own_folder(files):
    scene = str(files / "scenes" / "mine.toml")
    budgets = load_budgets(str(files / "budgets.toml"))
    assert budgets["scene_args"] == {"scenes/mine.toml": scene, "bunny": "bunny"}
    assert list(budgets["scenes"]) == ["scenes/mine.toml", "bunny"]   # named as the file names them
    assert spec_from_toml(str(files / "sweep.toml")).scenes == (scene, "bunny")
    assert resolve_scene(scene).name == "base"


def test_the_gate_finds_the_budgets_scene_from_another_working_directory(files, tmp_path, capsys, empty_cache):
    """Up to the first missing reference (no rendering: the gate without
    --render-references refuses, naming the reference, after resolving every scene)."""
    code = main(["gate", "--budgets", str(files / "budgets.toml"), "--scenes", "scenes/mine.toml",
                 "--out", str(tmp_path / "g"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "does not exist" not in err and "reference" in err, err
    assert not os.path.exists(tmp_path / "work" / "scenes")
