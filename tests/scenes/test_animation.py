"""Animated scenes: keyframe interpolation against hand-computed values, frames as
static scenes, and every malformed ``[animation]`` table named (file, key, value; exit 2)."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import tomli_w

try:
    import tomllib
except ModuleNotFoundError:
    import tomli as tomllib

from tests.shared import BASE_SCENE
from volcaustics.reports.cli import main
from volcaustics.scenes import SceneError, Transform, load_builtin, load_scene
from volcaustics.scenes.animation import FPS_RANGE, interpolate


def _doc(*tracks, frames=8, fps=12):
    doc = copy.deepcopy(tomllib.loads(BASE_SCENE))
    doc["animation"] = {"frames": frames, "fps": fps, "track": [dict(t) for t in tracks]}
    return doc


def _load(tmp_path, doc):
    path = tmp_path / "animated.toml"
    path.write_bytes(tomli_w.dumps(doc).encode())
    return str(path), load_scene(str(path))


def test_linear_keys_by_hand():
    """Keys at frames 0 and 4, (0,0,0) → (4,8,−4): frame 3 is 3/4 of the way; held outside."""
    frames, values = (0.0, 4.0, 6.0), ((0.0, 0.0, 0.0), (4.0, 8.0, -4.0), (4.0, 8.0, 0.0))
    assert interpolate(frames, values, 3, "linear", "point") == (3.0, 6.0, -3.0)
    assert interpolate(frames, values, 5, "linear", "point") == (4.0, 8.0, -2.0)
    assert interpolate(frames, values, -1, "linear", "point") == values[0]
    assert interpolate(frames, values, 9, "linear", "point") == values[-1]


def test_directions_slerp_at_constant_angular_speed():
    """x → y: a third of the way is 30° from x, half is the diagonal (a lerp would give
    (2/3, 1/3) normalised at a third: 26.6°)."""
    a, b = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    third = interpolate((0.0, 3.0), (a, b), 1, "slerp", "direction")
    assert np.allclose(third, (math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0), atol=1e-12)
    half = interpolate((0.0, 3.0), (a, b), 1.5, "slerp", "direction")
    assert np.allclose(half, (math.sqrt(0.5), math.sqrt(0.5), 0.0), atol=1e-12)


@pytest.mark.parametrize("start,end,u,expected", [
    ((0, 0, 0), (0, 90, 0), 0.5, (0, 45, 0)),          # about y: half the angle
    ((0, 0, 0), (90, 0, 0), 1 / 3, (30, 0, 0)),        # about x: a third
    ((0, 0, 10), (0, 0, 70), 0.5, (0, 0, 40)),         # about z, from a turned start
])
def test_rotations_slerp_by_hand(start, end, u, expected):
    """Euler keys (Transform's convention: about x, then y, then z) slerped: the frame's
    matrix is the hand-computed rotation's, whatever Euler triple represents it."""
    got = interpolate((0.0, 1.0), (start, end), u, "slerp", "euler")
    assert np.allclose(Transform(rotate=got).matrix(), Transform(rotate=expected).matrix(), atol=1e-12)


def test_rotation_convention_matches_the_transform():
    """A key's own value comes back as the same rotation (the Euler convention round trip)."""
    key = (10.0, 20.0, 30.0)
    got = interpolate((0.0, 2.0), (key, (50.0, -20.0, 5.0)), 1e-12, "slerp", "euler")
    assert np.allclose(Transform(rotate=got).matrix(), Transform(rotate=key).matrix(), atol=1e-9)


def test_frames_are_static_scenes(tmp_path):
    """Every track sets its field; light.target aims the light; the animation does not
    enter the static scene's hash, each frame has its own."""
    doc = _doc({"path": "light.position", "frame": [0, 4], "value": [[0, 3, 0], [2, 3, 0]]},
               {"path": "light.target", "frame": [0], "value": [[0, 1, 0]]},
               {"path": "medium.sigma_s", "frame": [0, 7], "value": [0.1, 0.8]},
               {"path": "specular.ball.translate", "frame": [0, 7], "value": [[0, 1, 0], [0, 1.7, 0]]},
               {"path": "specular.ball.scale", "frame": [0, 7], "value": [1.0, 0.3]},
               {"path": "camera.fov_y", "frame": [0, 7], "value": [40, 33]})
    _, scene = _load(tmp_path, doc)
    still = load_scene(_load(tmp_path, _doc(frames=1))[0])
    assert scene.scene_hash() == still.scene_hash()
    frame = scene.animation.scene_at(scene, 2)
    assert frame.animation is None
    assert frame.light.position == (1.0, 3.0, 0.0)
    assert np.allclose(frame.light.direction, np.array([-1.0, -2.0, 0.0]) / math.sqrt(5.0))
    assert frame.medium.sigma_s == pytest.approx((0.3, 0.3, 0.3))
    assert frame.medium.sigma_a == scene.medium.sigma_a
    assert frame.specular[0].mesh.transform.translate == pytest.approx((0.0, 1.2, 0.0))
    assert frame.specular[0].mesh.transform.scale == pytest.approx(0.8)
    assert frame.camera.fov_y == pytest.approx(38.0)
    hashes = {scene.animation.scene_at(scene, t).scene_hash() for t in range(8)}
    assert len(hashes) == 8
    with pytest.raises(ValueError, match="frame 8"):
        scene.animation.scene_at(scene, 8)


def test_builtin_animations_load():
    for name, path in (("bunny", "light.position"), ("refocus", "specular.sphere.translate"),
                       ("two_spheres", "medium.sigma_s")):
        scene = load_builtin(name)
        assert scene.animation is not None and path in [t.path for t in scene.animation.tracks]
        first, last = (scene.animation.scene_at(scene, t) for t in (0, scene.animation.frames - 1))
        assert first.scene_hash() != last.scene_hash()


TRACK = {"path": "light.position", "frame": [0, 4], "value": [[0, 3, 0], [1, 3, 0]]}

# (id, animation table mutation, key that must be named, text of the value that must be named)
BAD = [
    ("frames zero", lambda a: a.update(frames=0), "animation.frames", "0"),
    ("fps zero", lambda a: a.update(fps=0), "animation.fps", "0"),
    # below what the video writers store: a traceback after every frame had rendered
    ("fps tiny", lambda a: a.update(fps=1e-6), "animation.fps", "1e-06"),
    ("fps below the GIF's", lambda a: a.update(fps=0.005), "animation.fps", "0.005"),
    ("fps too high", lambda a: a.update(fps=1001), "animation.fps", "1001"),
    ("unknown key", lambda a: a.update(loop=True), "animation.loop", "True"),
    ("unknown path", lambda a: a["track"][0].update(path="light.colour"), "animation.track[0].path", "'light.colour'"),
    ("unknown object", lambda a: a["track"][0].update(path="specular.teapot.translate"), "animation.track[0].path",
     "'specular.teapot.translate'"),
    ("keys not increasing", lambda a: a["track"][0].update(frame=[3, 3]), "animation.track[0].frame[1]", "3"),
    ("negative key", lambda a: a["track"][0].update(frame=[-1, 3]), "animation.track[0].frame[0]", "-1"),
    ("values miscounted", lambda a: a["track"][0].update(value=[[0, 3, 0]]), "animation.track[0].value",
     "[[0, 3, 0]]"),
    ("value not a point", lambda a: a["track"][0].update(value=[[0, 3], [1, 3, 0]]), "animation.track[0].value[0]",
     "[0, 3]"),
    ("missing frame", lambda a: a["track"][0].pop("frame"), "animation.track[0].frame", "None"),
    ("track twice", lambda a: a["track"].append(dict(TRACK)), "animation.track[1].path", "'light.position'"),
    ("dark key", lambda a: a["track"].append({"path": "light.intensity", "frame": [0], "value": [0.0]}),
     "animation.track[1].value[0]", "[0.0, 0.0, 0.0]"),
    ("opposite directions", lambda a: a["track"].append({"path": "light.direction", "frame": [0, 2],
                                                         "value": [[0, -1, 0], [0, 1, 0]]}),
     "animation.track[1].value[1]", "[0.0, 1.0, 0.0]"),
    ("scale zero", lambda a: a["track"].append({"path": "specular.ball.scale", "frame": [0], "value": [0.0]}),
     "animation.track[1].value[0]", "0.0"),
    ("camera into the glass", lambda a: a["track"].append({"path": "camera.position", "frame": [0, 7],
                                                           "value": [[0, 1, 4], [0, 1, 0.2]]}),
     "camera.position", "animation frame 7"),
    ("fov near 180", lambda a: a["track"].append({"path": "camera.fov_y", "frame": [0, 7], "value": [40, 179.999]}),
     "animation.track[1].value[1]", "179.999"),
    ("light into the glass", lambda a: a["track"][0].update(frame=[0, 7], value=[[0, 3, 0], [0, 1, 0.1]]),
     "light.position", "inside specular[0] 'ball') (animation frame 6)"),
    ("glass onto the light", lambda a: a["track"].append({"path": "specular.ball.translate", "frame": [0, 7],
                                                          "value": [[0, 1, 0], [1, 3, 0]]}),
     "light.position", "inside specular[0] 'ball') (animation frame 6)"),
    ("light onto its target", lambda a: a["track"].append({"path": "light.target", "frame": [0],
                                                           "value": [[1, 3, 0]]}), "light.position", "frame 4"),
]


@pytest.mark.parametrize("mutate,key,value", [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_bad_animation_names_file_key_value(tmp_path, capsys, mutate, key, value):
    doc = _doc(dict(TRACK))
    mutate(doc["animation"])
    path = tmp_path / "animated.toml"
    path.write_bytes(tomli_w.dumps(doc).encode())
    with pytest.raises(SceneError) as info:
        load_scene(str(path))
    assert info.value.key == key, str(info.value)
    assert value in str(info.value) and str(path) in str(info.value)
    assert main(["scenes", "--check", str(path)]) == 2
    stderr = capsys.readouterr().err
    assert key in stderr and "Traceback" not in stderr


@pytest.mark.parametrize("fps", FPS_RANGE)
@pytest.mark.parametrize("fmt", ["mp4", "webp", "gif"])
def test_the_videos_are_written_at_both_ends_of_the_fps_range(tmp_path, fps, fmt):
    """The loader's fps bounds are what the writers accept: 24 frames written at each end."""
    from volcaustics.reports.studies.animate.media import write_mp4, write_web

    pictures = [np.full((16, 16, 3), 10 * i, np.uint8) for i in range(24)]
    path = str(tmp_path / f"video.{fmt}")
    write_mp4(path, pictures, fps) if fmt == "mp4" else write_web(path, pictures, fps, fmt)
    assert (tmp_path / f"video.{fmt}").stat().st_size > 0
    assert _load(tmp_path, _doc(dict(TRACK), fps=fps))[1].animation.fps == fps
