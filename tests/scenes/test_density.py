"""Heterogeneous media, scene side (scenes.density): the grid's convention, its majorants,
grid files, the scene hash, and every bad grid refused with the file, key and value named
(the CLI exits 2)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import tomli_w

try:
    import tomllib
except ModuleNotFoundError:
    import tomli as tomllib

from tests.shared import BASE_SCENE
from volcaustics.reports.cli import main
from volcaustics.scenes import SceneError, load_scene
from volcaustics.scenes.bounds import medium_bounds
from volcaustics.scenes.density import DensityGrid
from volcaustics.scenes.density_fields import fbm
from volcaustics.scenes.medium_grid import density_grid
from volcaustics.scenes.volume_files import read_grid, vol_bytes

BOX = {"min": [-5.0, -1.0, -5.0], "max": [5.0, 5.0, 5.0]}  # covers BASE_SCENE's medium box


def _scene_file(tmp_path, density) -> str:
    doc = tomllib.loads(BASE_SCENE)
    doc["medium"]["density"] = density
    path = tmp_path / "fog.toml"
    path.write_bytes(tomli_w.dumps(doc).encode())
    return str(path)


def _grid(rng, shape=(3, 4, 5)) -> DensityGrid:
    return DensityGrid(rng.random(shape).astype(np.float32), np.array([-1.0, 0.0, -2.0]), np.array([1.0, 2.0, 3.0]))


def test_grid_values_sit_at_cell_centres_and_interpolate_trilinearly():
    grid = _grid(np.random.default_rng(0))
    nx, ny, nz = grid.resolution
    i, j, k = 2, 1, 2
    centre = grid.lo + (np.array([i, j, k]) + 0.5) / np.array([nx, ny, nz]) * (grid.hi - grid.lo)
    assert grid.eval(centre[None])[0] == pytest.approx(float(grid.values[k, j, i]), abs=1e-6)
    # halfway between two centres along x: their mean; beyond the last centre: clamped
    step = (grid.hi - grid.lo)[0] / nx
    mid = centre + [0.5 * step, 0.0, 0.0]
    assert grid.eval(mid[None])[0] == pytest.approx(float(grid.values[k, j, i:i + 2].mean()), abs=1e-6)
    edge = np.array([grid.hi[0] - 1e-9, centre[1], centre[2]])
    assert grid.eval(edge[None])[0] == pytest.approx(float(grid.values[k, j, nx - 1]), abs=1e-6)
    # outside the box: 0 (negative control of the box test: just inside is not 0)
    assert grid.eval((grid.hi + 1e-6)[None])[0] == 0.0 and grid.eval((grid.hi - 1e-6)[None])[0] > 0.0


def test_majorants_bound_the_density_in_their_blocks():
    rng = np.random.default_rng(1)
    grid = _grid(rng, (9, 10, 11))
    block = 4
    majorants = grid.majorants(block)
    assert majorants.shape == (3, 3, 3)
    points = rng.uniform(grid.lo, grid.hi, (20000, 3))
    cells = np.floor((points - grid.lo) / (grid.hi - grid.lo) * grid.resolution).astype(int) // block
    bound = majorants[cells[:, 2], cells[:, 1], cells[:, 0]]
    assert np.all(grid.eval(points) <= bound + 1e-6)
    # ... and they are tight: a block's majorant is reached by a sample inside or beside it
    assert majorants.max() == grid.values.max()
    # negative control: the blocks' own maxima (no neighbours) are exceeded by interpolation somewhere
    own = np.array([[[grid.values[k * block:(k + 1) * block, j * block:(j + 1) * block, i * block:(i + 1) * block].max()
                      for i in range(3)] for j in range(3)] for k in range(3)])
    assert np.any(grid.eval(points) > own[cells[:, 2], cells[:, 1], cells[:, 0]] + 1e-6)


def test_vol_files_round_trip(tmp_path):
    grid = _grid(np.random.default_rng(2))
    path = tmp_path / "g.vol"
    path.write_bytes(vol_bytes(grid.values, grid.lo, grid.hi))
    values, box = read_grid(str(path))
    assert np.array_equal(values, grid.values)
    assert np.allclose(box[0], grid.lo) and np.allclose(box[1], grid.hi)


def test_fields_are_seeded_and_deterministic():
    points = np.random.default_rng(3).uniform(-2, 2, (500, 3))
    a, b, c = fbm(points, seed=4, octaves=3, frequency=2.0), fbm(points, seed=4, octaves=3, frequency=2.0), \
        fbm(points, seed=5, octaves=3, frequency=2.0)
    assert np.array_equal(a, b) and not np.allclose(a, c)
    assert a.min() >= 0.0 and a.max() < 1.0


def test_density_enters_the_scene_hash_and_homogeneous_hash_is_unchanged(tmp_path):
    plain = load_scene(_scene_file_without_density(tmp_path))
    fog = load_scene(_scene_file(tmp_path, {"field": "height_fog", "scale_height": 0.4}))
    thinner = load_scene(_scene_file(tmp_path, {"field": "height_fog", "scale_height": 0.3}))
    assert len({plain.scene_hash(), fog.scene_hash(), thinner.scene_hash()}) == 3
    assert "density" not in plain.canonical_json()  # a homogeneous medium's text is what it always was
    grid = density_grid(fog)
    lo, hi = medium_bounds(fog)
    assert np.allclose(grid.lo, lo) and np.allclose(grid.hi, hi) and grid.resolution == (32, 32, 32)


def _scene_file_without_density(tmp_path) -> str:
    path = tmp_path / "plain.toml"
    path.write_text(BASE_SCENE)
    return str(path)


def test_a_grid_file_loads_and_its_content_keys_the_scene(tmp_path):
    values = np.random.default_rng(6).random((4, 5, 6)).astype(np.float32)
    np.save(tmp_path / "smoke.npy", values)
    scene = load_scene(_scene_file(tmp_path, {"path": "smoke.npy", "box": BOX}))
    grid = density_grid(scene)
    assert np.array_equal(grid.values, values) and grid.resolution == (6, 5, 4)
    first = scene.scene_hash()
    np.save(tmp_path / "smoke.npy", values * 2)
    assert load_scene(_scene_file(tmp_path, {"path": "smoke.npy", "box": BOX})).scene_hash() != first


def _bad_npy(tmp_path, name, values) -> str:
    np.save(tmp_path / name, values)
    return name


GOOD = np.ones((4, 4, 4), np.float32)
NAN = GOOD.copy()
NAN[1, 2, 3] = np.nan
NEGATIVE = GOOD.copy()
NEGATIVE[0, 1, 2] = -0.5
# (id, the [medium.density] table (a callable of tmp_path), key named, text of the value named, text of the fix)
BAD = [
    ("missing file", lambda p: {"path": "nowhere.npy", "box": BOX}, "medium.density.path", "nowhere.npy",
     "No such file"),
    ("wrong shape", lambda p: {"path": _bad_npy(p, "flat.npy", np.ones((4, 4), np.float32)), "box": BOX},
     "medium.density.path", "flat.npy", "shape [nz, ny, nx]"),
    ("NaN", lambda p: {"path": _bad_npy(p, "nan.npy", NAN), "box": BOX}, "medium.density.path", "nan.npy",
     "[z=1, y=2, x=3] holds nan"),
    ("negative", lambda p: {"path": _bad_npy(p, "neg.npy", NEGATIVE), "box": BOX}, "medium.density.path",
     "neg.npy", "[z=0, y=1, x=2] holds -0.5"),
    ("not covering", lambda p: {"path": _bad_npy(p, "small.npy", GOOD), "box": {"min": [-1, 0, -1], "max": [1, 2, 1]}},
     "medium.density.box", "[1.0, 2.0, 1.0]", "must cover the medium box"),
    ("npy without box", lambda p: {"path": _bad_npy(p, "nobox.npy", GOOD)}, "medium.density.box", "None",
     "needs its box"),
    ("unknown field", lambda p: {"field": "smoke"}, "medium.density.field", "'smoke'", "height_fog"),
    ("not a grid file", lambda p: {"path": "fog.toml", "box": BOX}, "medium.density.path", "fog.toml", ".npy or .vol"),
    ("inverted box", lambda p: {"field": "height_fog", "box": {"min": [0, 0, 0], "max": [1, -1, 1]}},
     "medium.density.box.max", "[1.0, -1.0, 1.0]", "must exceed"),
]


@pytest.mark.parametrize("density,key,value,fix", [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_a_bad_grid_names_file_key_value_and_exits_2(tmp_path, capsys, density, key, value, fix):
    path = _scene_file(tmp_path, density(tmp_path))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert info.value.key == key and path in message and value in message and fix in message, message
    assert main(["scenes", "--check", path]) == 2
    stderr = capsys.readouterr().err
    assert key in stderr and "Traceback" not in stderr


def test_a_good_grid_passes_the_same_checks(tmp_path, capsys):
    """The negative control of the cases above: the same scene with a good grid loads."""
    path = _scene_file(tmp_path, {"path": _bad_npy(tmp_path, "good.npy", copy.copy(GOOD)), "box": BOX})
    assert main(["scenes", "--check", path]) == 0


def test_optical_depth_is_exact():
    """scenes.tracking.optical_depth against the trapezoid rule on 20,001 points for segments
    inside the box (2.5e-9 apart measured: the trapezoid's own error), and a slab of two
    densities whose faces lie on cell boundaries against its closed form: ∫ρ = 3·1 + 0.5·0.8."""
    from volcaustics.scenes.density import Density, baked_grid
    from volcaustics.scenes.tracking import optical_depth

    rng = np.random.default_rng(7)
    grid = _grid(rng, (6, 7, 8))
    start = rng.uniform(grid.lo, grid.hi, (300, 3))
    end = rng.uniform(grid.lo, grid.hi, (300, 3))
    d = end - start
    length = np.linalg.norm(d, axis=1)
    d /= length[:, None]
    exact = optical_depth(grid, start, d, length)
    s = np.linspace(0.0, 1.0, 20001)
    trapezoid = np.array([np.trapezoid(grid.eval(a + np.outer(s * n, u)), s) * n for a, u, n in zip(start, d, length)])
    assert np.abs(exact - trapezoid).max() < 1e-7
    slab = baked_grid(Density(field="box", params=(("inside", 3.0), ("max", (9.0, 0.5, 9.0)),
                                                    ("min", (-9.0, -0.5, -9.0)), ("outside", 0.5)),
                              resolution=(4, 8, 4)), (-1.0,) * 3, (1.0,) * 3)
    up = optical_depth(slab, np.array([[0.1, -0.9, 0.2]]), np.array([[0.0, 1.0, 0.0]]), np.array([1.8]))
    assert up[0] == pytest.approx(3.4, abs=1e-12)
    # beyond the box ρ = 0: a segment twice as long through and out of it gains nothing there
    out = optical_depth(slab, np.array([[0.1, -0.9, 0.2]]), np.array([[0.0, 1.0, 0.0]]), np.array([3.6]))
    assert out[0] == pytest.approx(3.4 + 0.5 * 0.1, abs=1e-12)
    # negative control: a midpoint rule of 4 steps misses the closed form
    h = 1.8 / 4
    midpoint = sum(slab.eval(np.array([[0.1, -0.9 + (k + 0.5) * h, 0.2]]))[0] for k in range(4)) * h
    assert abs(midpoint - 3.4) > 1e-3
