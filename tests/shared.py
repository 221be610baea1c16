"""What the tests share besides fixtures (those are in conftest.py): the measurement and
reference settings that keep tests fast, small scene files and scenes built in code, the
points the gate's tests measure, and what a failing image test leaves behind. Test modules
import from here, never from each other."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re

import numpy as np

from volcaustics.approx.light import spot_constants
from volcaustics.approx.params import QUICK
from volcaustics.experiment.measurement import MeasurementSettings
from volcaustics.infra.imageio import auto_exposure, write_exr, write_png
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.measuring import runner
from volcaustics.scenes.model import (
    Camera,
    DiffuseSurface,
    Medium,
    MeshSpec,
    Phase,
    Scene,
    SpecularObject,
    SpotLight,
    Transform,
)

# --- settings that keep a test fast -----------------------------------------------------
FAST_MEASUREMENT = ["--exact-subphotons", "1"]  # one exact replay per emission texel (the report's 16: its own tests)
SINGLE_SCATTERING = ["--max-scatter", "1"]      # no orders stream (the report's 8: the model term's tests)
# a sweep's small image, reference and measurement (tests/reports/test_sweep.py, test_best.py, test_report.py):
# tiny points, 32², photon_res 64, light_res 64; a single-scattering reference of 4 batches; one exact replay
# the small reference and measurement as a spec's or the budgets' tables (no braces: a .format template may hold it)
SMALL_REFERENCE_TABLES = """[reference]
photons = 65536
spp = 8
batches = 4
target_noise = "none"
max_scatter = 1
[measurement]
exact_subphotons = 1
"""
SWEEP_TABLES = """[set]
width = 32
height = 32
photon_res = 64
light_res = 64
""" + SMALL_REFERENCE_TABLES
SWEEP_SPEC = """
scenes = ["refocus"]
seeds = 1
[vary]
layers = [1, 2]
iterations = [4, 8]
""" + SWEEP_TABLES

# the gate's test points: refocus at 32², a small single-scattering reference, one exact replay
GATE_REFERENCE = ReferenceSettings(photons=1 << 16, spp=8, batches=4, target_noise=None, max_scatter=1)
GATE_POINT = runner.Point("refocus", dataclasses.replace(QUICK, width=32, height=32, photon_res=64, light_res=64),
                          seeds=2)
FULL_MEASUREMENT = MeasurementSettings(exact_subphotons=1)
# the closure tests' reference at 64² (its noise 10–100× below E_∞,s's there: caustic floors
# 0–0.09%), rendered once a run for every test that measures against it
CLOSURE_SIZE = 64
CLOSURE_REFERENCE = ReferenceSettings(photons=1 << 20, spp=32, batches=8, width=CLOSURE_SIZE, height=CLOSURE_SIZE)


def with_shared_references(root, shared_references):
    """``root`` made a cache folder whose ``reference/`` is the run's shared one (for a
    module-scoped fixture's own cache), and whose ``meshes/`` (generated meshes, written
    whole by rename as references are) is the run's too, beside it: Feline's takes 5 s to
    build in each process; returns ``root``."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "reference").symlink_to(shared_references, target_is_directory=True)
    meshes = shared_references.parent / "meshes"
    meshes.mkdir(exist_ok=True)
    (root / "meshes").symlink_to(meshes, target_is_directory=True)
    return root


# --- scenes ----------------------------------------------------------------------------
BASE_SCENE = """
name = "base"
description = "small valid scene for loader tests"

[camera]
position = [0.0, 1.0, 4.0]
target = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 64
height = 48

[light]
position = [0.0, 3.0, 0.0]
direction = [0.0, -1.0, 0.0]
intensity = [5.0, 5.0, 5.0]
cutoff_angle = 25.0
beam_width = 20.0

[medium]
sigma_s = 0.2
sigma_a = [0.01, 0.01, 0.01]
phase = "isotropic"

[[specular]]
name = "ball"
mesh = { generator = "sphere", radius = 0.5, subdivisions = 3 }
transform = { translate = [0.0, 1.0, 0.0] }
ior = 1.5
absorption = [0.0, 0.0, 0.0]

[[diffuse]]
name = "floor"
mesh = { generator = "quad", size_x = 4.0, size_z = 4.0 }
albedo = 0.5
"""

def sphere_spec(radius, center, subdivisions=48):
    return MeshSpec(generator="sphere", params=(("radius", float(radius)), ("subdivisions", subdivisions)),
                    transform=Transform(translate=tuple(float(c) for c in center)))


def shell_spec(radius, inner_radius, center, subdivisions=48):
    return MeshSpec(generator="shell", params=(("inner_radius", float(inner_radius)), ("radius", float(radius)),
                                               ("subdivisions", subdivisions)),
                    transform=Transform(translate=tuple(float(c) for c in center)))


def make_scene(specular=(), *, light_pos=(0.0, 3.0, 0.0), light_dir=(0.0, -1.0, 0.0), cutoff=20.0, beam=None,
               intensity=10.0, sigma_s=0.2, sigma_a=0.0, g=None, floor=True, camera=None, width=64, height=64):
    """specular: iterable of (MeshSpec, ior, absorption RGB)."""
    objs = tuple(SpecularObject(f"s{i}", spec, ior, tuple(ab)) for i, (spec, ior, ab) in enumerate(specular))
    diffuse = ()
    if floor:
        diffuse = (DiffuseSurface("floor", MeshSpec(generator="quad", params=(("size_x", 10.0), ("size_z", 10.0))),
                                  (0.5, 0.5, 0.5)),)
    cam = camera or Camera(position=(0.0, 1.2, 4.5), target=(0.0, 1.0, 0.0), fov_y=36.0, width=width, height=height)
    phase = Phase("hg", g) if g is not None else Phase()
    return Scene(name="test", camera=cam,
                 light=SpotLight(tuple(light_pos), tuple(np.asarray(light_dir) / np.linalg.norm(light_dir)),
                                 (intensity,) * 3, cutoff, beam if beam is not None else 0.75 * cutoff),
                 medium=Medium((sigma_s,) * 3, (sigma_a,) * 3, phase), specular=objs, diffuse=diffuse)


def ray_sphere(origin, dirs, center, radius):
    """Entry and exit distances of rays origin + t·dirs (...×3 unit) with a sphere; nan on a miss."""
    oc = np.asarray(origin, np.float64) - np.asarray(center, np.float64)
    b = dirs @ oc
    c = oc @ oc - radius * radius
    disc = b * b - c
    sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
    return -b - sq, -b + sq


def pixel_ray(cam, x, y):
    """Independent pinhole model: unit direction through image point (x, y) in pixels,
    x to the right from the left edge, y down from the top edge (pixel centres at +0.5)."""
    fwd = np.subtract(cam.target, cam.position).astype(float)
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, cam.up)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    half = np.tan(np.radians(cam.fov_y) / 2)
    d = fwd + (x / cam.width * 2 - 1) * half * cam.width / cam.height * right + (1 - y / cam.height * 2) * half * up
    return d / np.linalg.norm(d)


def spot_falloff64(light, w):
    """Mitsuba's spot falloff in float64 from its definition (spot.cpp): 1 inside
    beam_width, linear in angle to 0 at cutoff_angle."""
    cos_theta = float(np.dot(w, light.direction))
    cutoff, beam = np.radians(light.cutoff_angle), np.radians(light.beam_width)
    if cos_theta <= np.cos(cutoff):
        return 0.0
    if cos_theta >= np.cos(beam):
        return 1.0
    return float((cutoff - np.arccos(cos_theta)) / (cutoff - beam))


def optical_depth(density, a, b, n=801):
    """∫ρ along the segment a → b of a density grid (scenes.density.DensityGrid) by the
    trapezoid rule on n points: ρ is piecewise trilinear, so the rule's error is O(1/n²)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    t = np.linspace(0.0, 1.0, n)
    rho = density.eval(a + t[:, None] * (b - a))
    return float(np.trapezoid(rho, t) * np.linalg.norm(b - a))


def fog_quadrature(scene, eye, d, s_end, density=None):
    """Single scattering of the unoccluded spot light along eye + s·d, s in [0, s_end]:
    ∫ σs p(θ) I falloff(ω)/r² exp(−σt (r + s)) ds by scipy quadrature (red channel); with a
    ``density`` grid, σs and σt are scaled by ρ and the optical depths integrated along
    both legs (:func:`optical_depth`)."""
    from scipy import integrate

    light, medium = scene.light, scene.medium
    g = medium.phase.g if medium.phase.kind == "hg" else 0.0
    sigma_s, sigma_t = medium.sigma_s[0], medium.sigma_t[0]

    def integrand(s):
        x = eye + d * s
        to_x = x - np.asarray(light.position)
        r = np.linalg.norm(to_x)
        w = to_x / r
        cos_t = float(w @ -d)
        phase = (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * cos_t) ** 1.5)
        if density is None:
            rho, depth = 1.0, r + s
        else:
            rho = float(density.eval(x[None])[0])
            depth = optical_depth(density, eye, x) + optical_depth(density, x, light.position)
        return rho * sigma_s * phase * light.intensity[0] * spot_falloff64(light, w) / r**2 * np.exp(-sigma_t * depth)

    return integrate.quad(integrand, 0.0, s_end, limit=400, points=np.linspace(0, s_end, 40)[1:-1])[0]


def pixel_solid_angles(fov_y: float, size: int) -> tuple:
    """(edges, omega) of a square size × size image of vertical field of view fov_y
    (degrees): the pixel edges on the image plane at unit distance and each pixel's exact
    solid angle (size × size, rows bottom-up as GL draws them)."""
    half = math.tan(math.radians(fov_y) / 2)
    edges = np.linspace(-half, half, size + 1)

    def f(x, y):
        return np.arctan2(x * y, np.sqrt(1 + x * x + y * y))

    x0, y0 = np.meshgrid(edges[:-1], edges[:-1])
    x1, y1 = np.meshgrid(edges[1:], edges[1:])
    return edges, f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)


def flat_spot(light, d):
    """The spot without its profile: 1 inside the cutoff cone."""
    cos_theta = np.asarray(d, np.float32) @ np.asarray(light.direction, np.float32)
    return (cos_theta > np.float32(spot_constants(light)["spot_cos_cutoff"])).astype(np.float32)


# --- what a failing image test leaves behind: the images it compared, under test-output/ ---
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load_script(name: str):
    """The module of ``scripts/<name>.py``: the lint checks are scripts, not package
    modules, and their tests call their functions."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, os.path.join(ROOT, "scripts", f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def output_dir(test_name: str) -> str:
    """``test-output/<test_name>`` (characters outside [A-Za-z0-9._-] become ``_``), created."""
    base = os.environ.get("VOLCAUSTICS_TEST_OUTPUT") or os.path.join(ROOT, "test-output")
    folder = os.path.join(base, re.sub(r"[^A-Za-z0-9._-]+", "_", test_name).strip("_"))
    os.makedirs(folder, exist_ok=True)
    return folder


def write_compared_images(test_name: str, layers: dict, *, info: dict | None = None,
                          exposure_from: str | None = None, own_exposure: tuple = ()) -> str:
    """Write ``layers`` (name → H×W×3 or H×W float array, linear) to
    ``test-output/<test_name>/compared.exr``, one PNG per H×W×3 layer (the exposure of
    ``exposure_from`` except for the layers in ``own_exposure``, which get their own;
    negative values are written as their magnitude) and ``info.json``; returns the folder."""
    folder = output_dir(test_name)
    write_exr(os.path.join(folder, "compared.exr"), {k: np.asarray(v, np.float32) for k, v in layers.items()})
    exposure = auto_exposure(np.abs(layers[exposure_from])) if exposure_from else None
    for name, image in layers.items():
        image = np.abs(np.asarray(image, np.float32))
        if image.ndim == 3 and image.shape[2] == 3:
            write_png(os.path.join(folder, f"{name}.png"), image, None if name in own_exposure else exposure)
    if info is not None:
        with open(os.path.join(folder, "info.json"), "w", encoding="utf-8") as fh:
            json.dump(info, fh, indent=2, default=lambda x: np.asarray(x).tolist())
    return folder


def media_scene(name: str):
    """The heterogeneous medium's scene ``name``: fogbank and smoke are media scenes (named),
    layered_fog is held out."""
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.catalogue import HELDOUT_NAMES, heldout_path

    return resolve_scene(heldout_path(name) if name in HELDOUT_NAMES else name)


def media_renderer(name: str):
    """(scene, Renderer) for a heterogeneous medium's scene ``name`` (:func:`media_scene`):
    a generator for a module fixture (released after it)."""
    from volcaustics.approx import Renderer

    scene = media_scene(name)
    renderer = Renderer(scene)
    try:
        yield scene, renderer
    finally:
        renderer.release()


# the exact replay's engine comparisons: 1,600 photons a replay, 3 replays (about a second a scene)
REPLAY_PHOTON_RES = 40


def replay_differences(a, b) -> list:
    """What differs between two replays' collisions (empty: the same to the records' float32)."""
    wrong = []
    for k, (x, y) in enumerate(zip(a, b)):
        if len(x.rows) != len(y.rows):
            wrong.append(f"replay {k}: {len(x.rows)} against {len(y.rows)} collisions")
            continue
        for field in x.rows.dtype.names:
            if not np.array_equal(x.rows[field], y.rows[field]):
                wrong.append(f"replay {k}: {field} differs in {int((x.rows[field] != y.rows[field]).sum())} values")
        for budget in ("emitted_power", "alive_power", "collided_power"):
            # float64 sums of float32 values: Dr.Jit's exp may differ from numpy's in the last bit of a float64
            if not np.allclose(getattr(x, budget), getattr(y, budget), rtol=1e-12, atol=0.0):
                wrong.append(f"replay {k}: {budget} differs")
    return wrong
