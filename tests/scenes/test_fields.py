"""scenes.fields: a scene with fields changed by dotted path, validated as the loader
validates a file (each bad input a SceneError naming the key), and the optical depth."""

from __future__ import annotations

import math

import pytest

from volcaustics.scenes import SceneError, resolve_scene
from volcaustics.scenes.catalogue import builtin_path
from volcaustics.scenes.fields import field_columns, optical_depth, parse_field_value, scene_with


def test_a_changed_field_is_the_scene_with_that_value():
    base = resolve_scene("bunny")
    thick = scene_with("bunny", {"medium.sigma_s": 0.5, "specular.0.ior": 1.33})
    assert thick.medium.sigma_s == (0.5, 0.5, 0.5) and thick.specular[0].ior == 1.33
    assert thick.medium.sigma_a == base.medium.sigma_a and thick.camera == base.camera
    assert thick.scene_hash() != base.scene_hash()
    assert scene_with("bunny", ()).scene_hash() == base.scene_hash()  # no change: the same scene
    rgb = scene_with("bunny", [("light.intensity", [1.0, 2.0, 3.0])])
    assert rgb.light.intensity == (1.0, 2.0, 3.0)


def test_a_scene_file_by_path(tmp_path):
    path = tmp_path / "mine.toml"
    with open(builtin_path("refocus"), encoding="utf-8") as fh:
        path.write_text(fh.read().replace('name = "refocus"', 'name = "mine"'))
    changed = scene_with(str(path), {"medium.sigma_a": 0.1})
    assert changed.name == "mine" and changed.medium.sigma_a == (0.1,) * 3
    assert changed.source == str(path)


@pytest.mark.parametrize("fields, key, words", [
    ({"medium.sigma_s": -1}, "medium.sigma_s", "expected a number"),
    ({"medium.sigma_x": 1}, "medium.sigma_x", "unknown key"),
    ({"specular.3.ior": 1.5}, "specular.3", "1 specular object"),
    ({"specular.0.ior": 0.5}, "specular[0].ior", "[1.0, 10.0]"),
    ({"specular.ior": 1.5}, "specular.ior", "give its index"),
    ({"fog.sigma_s": 1}, "fog.sigma_s", "TABLE one of"),
    ({"light.cutoff_angle": "wide"}, "light.cutoff_angle", "number"),
    ({"specular.².ior": 1.5}, "specular.².ior", "give its index"),
    ({"camera.height": 64}, "camera.height", "--set height=N"),
    ({"light.position.0": 1.0}, "light.position.0", "element of a list"),
])
def test_bad_fields_name_the_key(fields, key, words):
    with pytest.raises(SceneError) as info:
        scene_with("bunny", fields)
    assert info.value.key == key and words in str(info.value)
    if key in fields:  # the value given, not None
        assert info.value.value == fields[key], str(info.value)


def test_values_parse_as_toml_or_words():
    assert parse_field_value("medium.sigma_s", "0.25") == 0.25
    assert parse_field_value("medium.sigma_s", "[0.1, 0.2, 0.3]") == (0.1, 0.2, 0.3)  # hashable
    assert parse_field_value("medium.sigma_s", [0.1, 0.2, 0.3]) == (0.1, 0.2, 0.3)
    for bad in ("{a = 1}", "[[0.1], [0.2]]", {"a": 1}):
        with pytest.raises(SceneError, match="a number, a word or a list"):
            parse_field_value("medium.sigma_s", bad)
    assert parse_field_value("medium.phase", "hg") == "hg"
    assert parse_field_value("medium.sigma_s", 3) == 3  # from TOML, as it is
    assert field_columns({"medium.sigma_s": [0.1, 0.2, 0.3], "medium.g": 0.5}) == pytest.approx(
        {"medium.sigma_s": 0.2, "medium.g": 0.5})


def test_optical_depth_is_extinction_times_the_light_to_eye_path():
    scene = resolve_scene("sphere1")
    light, target, eye = scene.light.position, scene.camera.target, scene.camera.position
    length = math.dist(light, target) + math.dist(target, eye)
    assert optical_depth(scene) == pytest.approx(scene.medium.sigma_bar * length)
    assert optical_depth(scene_with("sphere1", {"medium.sigma_s": 0.0, "medium.sigma_a": 0.0})) == 0.0
    doubled = scene_with("sphere1", {"medium.sigma_s": 0.4, "medium.sigma_a": 0.04})
    assert optical_depth(doubled) == pytest.approx(2 * optical_depth(scene))
