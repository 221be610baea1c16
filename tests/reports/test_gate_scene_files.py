"""The gate with a budgets entry keyed by a scene file (``[scene."mine/scene.toml"]``):
the baseline it accepts is keyed as the budgets file writes the entry, and the next run
finds it there. The store kept it under that key and looked it up under the scene's
own name ("base"): every later run exited 2 with "the baseline has no entry"."""

from __future__ import annotations

import json

from tests.shared import BASE_SCENE, SMALL_REFERENCE_TABLES
from volcaustics.reports.cli import main

# tiny points (32², photon_res 64, light_res 64, 2 seeds) against a small single-scattering reference
SIZE = ["--set", "width=32", "--set", "height=32", "--set", "photon_res=64", "--set", "light_res=64", "--quiet"]
# a limit no frame comes near: the test is of the baseline's key, not of the budget
BUDGETS = f"""preset = "quick"
seeds = 2
{SMALL_REFERENCE_TABLES}
[scene."mine/scene.toml"]
caustic = {{ relmse_max = 1000.0 }}
"""


def test_a_budgets_entry_keyed_by_a_scene_file_reads_back_its_own_baseline(cache, tmp_path, capsys):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "scene.toml").write_text(BASE_SCENE)  # its scene's name is "base"
    (tmp_path / "budgets.toml").write_text(BUDGETS)
    gate = ["gate", "--budgets", str(tmp_path / "budgets.toml"), "--baseline", str(tmp_path / "baseline"), *SIZE]
    assert main([*gate, "--update-baseline", "--render-references", "--out", str(tmp_path / "g1")]) == 0
    capsys.readouterr()
    accepted = json.loads((tmp_path / "baseline" / "baseline.json").read_text())
    assert list(accepted["scenes"]) == ["mine/scene.toml"]  # the key as the budgets file writes it
    # the next run (from the store: nothing measured) tests against that entry
    assert main([*gate, "--out", str(tmp_path / "g2")]) == 0, capsys.readouterr().err
    checks = json.loads((tmp_path / "g2" / "gate.json").read_text())["checks"]
    assert [c["scene"] for c in checks if c["name"] == "regression.caustic_relmse"] == ["mine/scene.toml"]


def test_the_report_checks_a_scene_files_budgets_and_baseline_under_its_key(cache, tmp_path, capsys):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "scene.toml").write_text(BASE_SCENE)  # its scene's name is "base"
    (tmp_path / "budgets.toml").write_text(BUDGETS)
    budgets, baseline = ["--budgets", str(tmp_path / "budgets.toml")], ["--baseline", str(tmp_path / "baseline")]
    assert main(["gate", *budgets, *baseline, *SIZE, "--update-baseline", "--render-references",
                 "--out", str(tmp_path / "g")]) == 0
    # the report names the scene file from elsewhere (another spelling of the same file)
    spelt = str(tmp_path / "mine" / ".." / "mine" / "scene.toml")
    assert main(["report", *budgets, *baseline, *SIZE, "--scenes", spelt, "--out", str(tmp_path / "r")]) == 0, \
        capsys.readouterr().err
    page = json.loads((tmp_path / "r" / "summary.json").read_text())["scenes"][0]
    gate = page["gate"]
    assert [(c["scene"], c["name"]) for c in gate["checks"]] == [("mine/scene.toml", "caustic.relmse_max")], gate
    assert "no entry" not in gate["note"], gate  # the baseline's entry found under the same key
