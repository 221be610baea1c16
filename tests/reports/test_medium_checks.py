"""A medium with no volume caustic to measure is refused before any reference renders: no
scattering in a channel, or an optical depth no reference can light."""

from __future__ import annotations

import pytest

from tests.shared import SWEEP_TABLES
from volcaustics.reports.cli import main


@pytest.mark.parametrize("sigma_s, words", [
    ("0.0", "a channel without scattering"),
    ("[0.2, 0.0, 0.2]", "a channel without scattering"),
    ("1e3", "optical depth"),
    ("1e9", "optical depth"),
])
def test_a_sweep_over_a_medium_without_a_caustic_is_refused_up_front(tmp_path, capsys, empty_cache, sigma_s, words):
    spec = tmp_path / "spec.toml"
    spec.write_text(f'scenes = ["sphere1"]\nseeds = 1\n[vary]\n"medium.sigma_s" = [0.1, {sigma_s}]\n'
                    + SWEEP_TABLES)
    assert main(["sweep", str(spec), "-o", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert words in err and "medium.sigma_s" in err and "Traceback" not in err, err
    assert not (empty_cache / "reference").exists()


@pytest.mark.parametrize("command", ["measure", "compare"])
def test_a_scene_file_without_scattering_is_refused_by_measure_and_compare(tmp_path, capsys, empty_cache,
                                                                            write_scene, command):
    from tests.shared import BASE_SCENE

    scene = write_scene(BASE_SCENE.replace("sigma_s = 0.2", "sigma_s = 0.0"))
    image = tmp_path / "image.exr"
    image.write_bytes(b"not read")
    args = {"measure": ["measure", scene, "-o", str(tmp_path / "out")],
            "compare": ["compare", scene, str(image), "-o", str(tmp_path / "out")]}[command]
    assert main([*args, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "a channel without scattering" in err and "Traceback" not in err, err
    assert not (empty_cache / "reference").exists()


def test_the_builtins_pass_the_medium_check():
    """The negative control: every built-in is measurable (the check refuses nothing real)."""
    from volcaustics.experiment.point_checks import MAX_OPTICAL_DEPTH, check_medium
    from volcaustics.scenes import BUILTIN_NAMES, load_builtin
    from volcaustics.scenes.fields import optical_depth

    for name in BUILTIN_NAMES:
        scene = load_builtin(name)
        check_medium(scene)
        assert optical_depth(scene) < MAX_OPTICAL_DEPTH / 4, name
