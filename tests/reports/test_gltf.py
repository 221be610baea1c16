"""glTF 2.0 export (reports/presenting/exports/gltf.py): every built-in passes the Khronos glTF-Validator
with no error, a broken file does not (the hook reports), and everything read back with
pygltflib is the scene: transforms, meshes in world space, normals, glass, albedo, light,
camera and the extras glTF has no field for."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import urllib.parse

import numpy as np
import pytest
from pygltflib import GLTF2

from volcaustics.reports.presenting.exports.gltf import export_gltf, unit_vertex_normals
from volcaustics.reports.presenting.exports.gltf_parts import CONE_GAP, EXTRAS_KEY, quaternion
from volcaustics.scenes import BUILTIN_NAMES, Phase, Transform, resolve_scene
from volcaustics.scenes.density import Density
from volcaustics.scenes.formats import LAYER_NAMES
from volcaustics.scenes.medium_grid import density_grid
from volcaustics.scenes.volume_files import read_grid

from .gltf_validator import ValidatorUnavailable, validate_gltf

# Tolerances. What the JSON holds is float64 (TRS, angles, colours, IOR): back to 1e-12,
# the quaternion's rebuild included. Vertex data is float32: 2^-24 relative per coordinate
# (object space, then times the node's scale), so world positions to 1e-6 of the scene's
# size and unit normals to 1e-6.
JSON_TOL = 1e-12
FLOAT32_TOL = 1e-6

_DTYPES = {5126: np.float32, 5125: np.uint32}
_WIDTHS = {"SCALAR": 1, "VEC3": 3}


def _placed_scene():
    """A scene that exercises what the built-ins leave out: a rotation in every axis
    (each branch of the quaternion), a scale, RGB absorption on a rotated object, an HG
    phase, beam_width == cutoff_angle (glTF wants inner < outer) and a camera with a
    tilted up."""
    scene = resolve_scene("two_spheres")
    clear, green = scene.specular
    clear = dataclasses.replace(clear, absorption=(0.5, 0.0, 2.5), ior=1.33,
                                mesh=dataclasses.replace(clear.mesh, transform=Transform(
                                    translate=(0.1, 1.5, -0.2), rotate=(30.0, 200.0, -70.0), scale=0.7)))
    green = dataclasses.replace(green, mesh=dataclasses.replace(green.mesh, transform=Transform(
        translate=(0.0, 0.55, 0.0), rotate=(180.0, 0.0, 0.0), scale=1.2)))
    light = dataclasses.replace(scene.light, beam_width=scene.light.cutoff_angle)
    camera = dataclasses.replace(scene.camera, up=(0.3, 1.0, 0.1), width=640, height=360)
    medium = dataclasses.replace(scene.medium, phase=Phase("hg", 0.6))
    return dataclasses.replace(scene, name="placed", specular=(clear, green), light=light, camera=camera,
                               medium=medium, animation=None)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """name → (scene, path): every built-in as .glb, bunny and sphere2 also as .gltf +
    .bin, the placed scene as .glb."""
    folder = tmp_path_factory.mktemp("gltf")
    out = {}
    for name in BUILTIN_NAMES:
        scene = resolve_scene(name)
        out[name] = (scene, str(folder / f"{name}.glb"))
    out["bunny.gltf"] = (out["bunny"][0], str(folder / "bunny.gltf"))
    out["spaced.gltf"] = (out["sphere2"][0], str(folder / "a scene #1.gltf"))  # its buffer's uri is escaped
    out["placed"] = (_placed_scene(), str(folder / "placed.glb"))
    out["fog"] = (_fog_scene(), str(folder / "fog.gltf"))
    for scene, path in out.values():
        export_gltf(scene, path)
    return out


@pytest.fixture(scope="module")
def broken(exported):
    """Two files the validator must refuse, made from the exported bunny.gltf (same
    folder: its .bin resolves): innerConeAngle = outerConeAngle, POSITION without min/max."""
    path = exported["bunny.gltf"][1]
    with open(path, encoding="utf-8") as fh:
        doc = json.load(fh)
    cone = json.loads(json.dumps(doc))
    spot = cone["extensions"]["KHR_lights_punctual"]["lights"][0]["spot"]
    spot["innerConeAngle"] = spot["outerConeAngle"]
    bounds = json.loads(json.dumps(doc))
    position = bounds["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
    del bounds["accessors"][position]["min"], bounds["accessors"][position]["max"]
    out = {}
    for name, text in (("cone", cone), ("bounds", bounds)):
        out[name] = os.path.join(os.path.dirname(path), f"broken_{name}.gltf")
        with open(out[name], "w", encoding="utf-8") as fh:
            json.dump(text, fh)
    return out


@pytest.fixture(scope="module")
def reports(exported, broken):
    """path → the validator's report, for every file above (one Node start)."""
    try:
        _, found = validate_gltf([path for _, path in exported.values()] + list(broken.values()))
    except ValidatorUnavailable as exc:
        pytest.skip(str(exc))
    return found


# --- the validator ---------------------------------------------------------------------

@pytest.mark.parametrize("name", [*BUILTIN_NAMES, "bunny.gltf", "spaced.gltf", "placed", "fog"])
def test_the_validator_finds_no_error(reports, exported, name):
    issues = reports[exported[name][1]]["issues"]
    assert issues["numErrors"] == 0, issues["messages"]
    # measured with gltf-validator 2.0.0-dev.3.10: no warning, info or hint either
    assert issues["numWarnings"] == issues["numInfos"] == 0, issues["messages"]


@pytest.mark.parametrize("what, code", [("cone", "KHR_LIGHTS_PUNCTUAL_LIGHT_SPOT_ANGLES"),
                                        ("bounds", "MESH_PRIMITIVE_POSITION_ACCESSOR_WITHOUT_BOUNDS")])
def test_a_broken_file_gives_errors(reports, broken, what, code):
    """The negative control: the hook reports what the validator finds."""
    issues = reports[broken[what]]["issues"]
    assert issues["numErrors"] > 0 and code in [m["code"] for m in issues["messages"] if m["severity"] == 0], issues


# --- reading back ------------------------------------------------------------------------

def _read(path):
    """(GLTF2, its binary buffer) of a .glb or a .gltf with its .bin."""
    gltf = GLTF2().load(path)
    if path.endswith(".glb"):
        return gltf, gltf.binary_blob()
    with open(os.path.join(os.path.dirname(path), urllib.parse.unquote(gltf.buffers[0].uri)), "rb") as fh:
        return gltf, fh.read()


def _array(gltf, blob, index) -> np.ndarray:
    accessor = gltf.accessors[index]
    view = gltf.bufferViews[accessor.bufferView]
    width = _WIDTHS[accessor.type]
    data = np.frombuffer(blob, _DTYPES[accessor.componentType], accessor.count * width,
                         (view.byteOffset or 0) + (accessor.byteOffset or 0))
    return data.reshape(accessor.count, width) if width > 1 else data


def _rotation(q) -> np.ndarray:
    """3×3 matrix of a unit quaternion [x, y, z, w]."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _node_matrix(node) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = _rotation(node.rotation or [0, 0, 0, 1]) * np.asarray(node.scale or [1, 1, 1])
    m[:3, 3] = node.translation or [0, 0, 0]
    return m


ROUND_TRIP = [*BUILTIN_NAMES, "bunny.gltf", "spaced.gltf", "placed"]


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_objects_come_back(exported, name):
    scene, path = exported[name]
    gltf, blob = _read(path)
    nodes = {node.name: node for node in gltf.nodes}
    assert len(gltf.nodes) == len(scene.specular) + len(scene.diffuse) + 2  # + light, camera
    for obj in (*scene.specular, *scene.diffuse):
        node = nodes[obj.name]
        matrix = _node_matrix(node)
        np.testing.assert_allclose(matrix, obj.mesh.transform.matrix(), rtol=0, atol=JSON_TOL)
        primitive = gltf.meshes[node.mesh].primitives[0]
        world = obj.mesh.load()
        position = _array(gltf, blob, primitive.attributes.POSITION).astype(np.float64)
        faces = _array(gltf, blob, primitive.indices).reshape(-1, 3)
        assert len(position) == len(world.vertices) and np.array_equal(faces, world.faces)
        placed = position @ matrix[:3, :3].T + matrix[:3, 3]
        np.testing.assert_allclose(placed, world.vertices, rtol=0,
                                   atol=FLOAT32_TOL * max(1.0, np.abs(world.vertices).max()))
        normal = _array(gltf, blob, primitive.attributes.NORMAL).astype(np.float64)
        np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, rtol=0, atol=FLOAT32_TOL)
        rotation = matrix[:3, :3] / obj.mesh.transform.scale
        expected = world.vertex_normals()
        shading = np.linalg.norm(expected, axis=1) > 0.5  # not the skull's vertex that only zero-area faces touch
        np.testing.assert_allclose((normal @ rotation.T)[shading], expected[shading], rtol=0, atol=FLOAT32_TOL)


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_materials_come_back(exported, name):
    scene, path = exported[name]
    gltf, _ = _read(path)
    nodes = {node.name: node for node in gltf.nodes}

    def material(obj):
        return gltf.materials[gltf.meshes[nodes[obj.name].mesh].primitives[0].material]

    for obj in scene.specular:
        glass = material(obj)
        assert glass.extensions["KHR_materials_transmission"]["transmissionFactor"] == 1.0
        assert glass.extensions["KHR_materials_ior"]["ior"] == obj.ior
        pbr = glass.pbrMetallicRoughness
        assert (pbr.baseColorFactor, pbr.metallicFactor, pbr.roughnessFactor) == ([1.0] * 4, 0.0, 0.0)
        volume = glass.extensions["KHR_materials_volume"]
        assert volume["thicknessFactor"] > 0
        if any(obj.absorption):
            absorption = -np.log(volume["attenuationColor"]) / volume["attenuationDistance"]
            np.testing.assert_allclose(absorption, obj.absorption, rtol=JSON_TOL, atol=JSON_TOL)
        else:  # no attenuation: an infinite distance, glTF's default
            assert "attenuationColor" not in volume and "attenuationDistance" not in volume
        assert glass.extras[EXTRAS_KEY]["absorption_per_m"] == list(obj.absorption)
    for obj in scene.diffuse:
        pbr = material(obj).pbrMetallicRoughness
        assert pbr.baseColorFactor == [*obj.albedo, 1.0]
        assert (pbr.metallicFactor, pbr.roughnessFactor) == (0.0, 1.0)


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_light_and_camera_come_back(exported, name):
    scene, path = exported[name]
    gltf, _ = _read(path)
    nodes = {node.name: node for node in gltf.nodes}
    light = scene.light
    node = nodes["spot_light"]
    spot = gltf.extensions["KHR_lights_punctual"]["lights"][node.extensions["KHR_lights_punctual"]["light"]]
    assert node.translation == list(light.position)
    np.testing.assert_allclose(_rotation(node.rotation) @ [0, 0, -1], light.direction, rtol=0, atol=JSON_TOL)
    np.testing.assert_allclose(np.multiply(spot["color"], spot["intensity"]), light.intensity, rtol=JSON_TOL)
    assert max(spot["color"]) == 1.0
    assert spot["spot"]["outerConeAngle"] == math.radians(light.cutoff_angle)
    extras = spot["extras"][EXTRAS_KEY]
    assert extras["intensity_W_per_sr"] == list(light.intensity)
    assert (extras["cutoff_angle_deg"], extras["beam_width_deg"]) == (light.cutoff_angle, light.beam_width)
    if light.beam_width < light.cutoff_angle:
        assert spot["spot"]["innerConeAngle"] == math.radians(light.beam_width)
        assert "innerConeAngle_adjusted" not in extras
    else:
        assert spot["spot"]["innerConeAngle"] == pytest.approx(math.radians(light.cutoff_angle) - CONE_GAP,
                                                               abs=JSON_TOL)
        assert "innerConeAngle_adjusted" in extras
    camera = scene.camera
    node = nodes["camera"]
    perspective = gltf.cameras[node.camera].perspective
    assert perspective.yfov == math.radians(camera.fov_y)
    assert perspective.aspectRatio == camera.width / camera.height
    assert perspective.znear > 0 and perspective.zfar is None
    assert node.translation == list(camera.position)
    rotation = _rotation(node.rotation)
    np.testing.assert_allclose(rotation @ [0, 0, -1], camera.forward, rtol=0, atol=JSON_TOL)
    up = np.asarray(camera.up) - np.dot(camera.up, camera.forward) * camera.forward  # up made orthogonal
    np.testing.assert_allclose(rotation @ [0, 1, 0], up / np.linalg.norm(up), rtol=0, atol=JSON_TOL)


@pytest.mark.parametrize("name", ["bunny", "placed"])
def test_the_scene_extras_hold_what_gltf_cannot(exported, name):
    scene, path = exported[name]
    gltf, _ = _read(path)
    extras = gltf.scenes[gltf.scene].extras[EXTRAS_KEY]
    assert extras["scene_hash"] == scene.scene_hash()
    medium = extras["medium"]
    assert (medium["sigma_s"], medium["sigma_a"]) == (list(scene.medium.sigma_s), list(scene.medium.sigma_a))
    assert medium["phase"] == {"kind": scene.medium.phase.kind, "g": scene.medium.phase.g}
    assert (extras["image"]["width"], extras["image"]["height"]) == (scene.camera.width, scene.camera.height)
    assert "box" in extras["image"]["pixel_filter"]
    assert tuple(extras["layers"]) == LAYER_NAMES
    assert ("animation" in extras) == (scene.animation is not None)  # bunny is animated: only its rest is here
    assert gltf.asset.generator == "volcaustics" and gltf.asset.version == "2.0"


def _fog_scene():
    """sphere2 in a plume of smoke: a heterogeneous medium."""
    scene = resolve_scene("sphere2")
    plume = Density(field="plume", params=(("center", (0.0, 0.0, 0.0)), ("radius", 0.4)), resolution=(8, 12, 8))
    return dataclasses.replace(scene, medium=dataclasses.replace(scene.medium, density=plume))


def test_a_heterogeneous_medium_travels_as_a_side_file(exported):
    scene, path = exported["fog"]
    gltf, _ = _read(path)
    density = gltf.scenes[gltf.scene].extras[EXTRAS_KEY]["medium"]["density"]
    assert gltf.scenes[gltf.scene].extras[EXTRAS_KEY]["medium"]["kind"] == "heterogeneous"
    side = os.path.join(os.path.dirname(path), density["file"])
    assert density["file"] == "fog_density.vol" and os.path.isfile(side)
    values, (lo, hi) = read_grid(side)
    grid = density_grid(scene)
    assert np.array_equal(values, grid.values) and np.allclose(lo, grid.lo) and np.allclose(hi, grid.hi)
    assert density["resolution"] == [8, 12, 8] and density["source"]["field"] == "plume"
    # negative control: a homogeneous scene writes no side file and says so
    homogeneous = gltf_scene_extras(exported["placed"][1])
    assert homogeneous["medium"]["kind"] == "homogeneous" and "density" not in homogeneous


def gltf_scene_extras(path):
    gltf, _ = _read(path)
    return gltf.scenes[gltf.scene].extras[EXTRAS_KEY]


# --- pieces --------------------------------------------------------------------------------

@pytest.mark.parametrize("rotate", [(0, 0, 0), (180, 0, 0), (0, 180, 0), (0, 0, 180), (30, 200, -70),
                                    (90, 90, 90), (-179, 1, 179)])
def test_quaternion_rebuilds_the_rotation(rotate):
    r = Transform(rotate=rotate).matrix()[:3, :3]
    q = quaternion(r)
    assert q[3] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-15
    np.testing.assert_allclose(_rotation(q), r, rtol=0, atol=1e-14)


def test_zero_normals_become_unit(exported):
    """The skull stand-in has a vertex that only zero-area faces touch (vertex_normals: 0):
    glTF wants unit normals (the validator's ACCESSOR_VECTOR3_NON_UNIT otherwise)."""
    obj = exported["skull"][0].specular[0]
    mesh = dataclasses.replace(obj.mesh, transform=Transform()).load()
    zero = np.linalg.norm(mesh.vertex_normals(), axis=1) < 0.5
    assert zero.any()
    np.testing.assert_allclose(np.linalg.norm(unit_vertex_normals(mesh), axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("name", ["out.png", "out.glb.txt", "out"])
def test_another_extension_is_refused(tmp_path, name):
    with pytest.raises(ValueError, match=r"\.glb .*\.gltf"):
        export_gltf(resolve_scene("sphere2"), str(tmp_path / name))
    assert not list(tmp_path.iterdir())
