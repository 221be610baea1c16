"""The reference in heterogeneous media (scenes.density): its trackers against closed forms,
its images against Mitsuba's own ``volpath`` with a ``heterogeneous`` medium, against 1-D
quadrature and against itself through another estimator; a grid of ones against the
homogeneous medium. Each has a negative control it must flag: a tracker that ignores the
grid, a majorant below the density, a density off by 15%.

The slab: a grid over [-1, 1]³ of 4 × 8 × 4 cells with ρ = 3 for |y| < 0.5 and 0.5 elsewhere.
Its faces lie on cell boundaries, so the trilinear ramp across each face (between the
centres on either side) integrates exactly as the step does: a ray from y = −0.9 to 0.9
crosses ∫ρ = 3·1.0 + 0.5·0.8 = 3.4."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.reference.agreement import agree, integrator_batches
from tests.shared import fog_quadrature, make_scene, pixel_ray, sphere_spec
from volcaustics.reference.mi_setup import mitsuba
from volcaustics.reference.render.camera_integrator import SingleScatterIntegrator
from volcaustics.reference.render.export import to_mitsuba
from volcaustics.reference.render.integrators import VolumetricLightTracer, configure
from volcaustics.reference.render.tracking import TrackedMedium
from volcaustics.scenes.density import Density
from volcaustics.scenes.medium_grid import density_grid
from volcaustics.scenes.model import Camera, Medium, Phase

mi = mitsuba()

SIGMA_T = 0.4
SLAB = Density(field="box", params=(("inside", 3.0), ("max", (9.0, 0.5, 9.0)), ("min", (-9.0, -0.5, -9.0)),
                                    ("outside", 0.5)), resolution=(4, 8, 4), box=((-1.0,) * 3, (1.0,) * 3))
SLAB_DEPTH = 3.4  # ∫ρ from y = -0.9 to 0.9 (module docstring)
LANES = 200_000


def _slab_scene():
    """A scene whose medium is the slab (grey σt = SIGMA_T, albedo 0.8) and whose medium box
    lies inside the slab's grid (light and camera within [-1, 1]³)."""
    cam = Camera(position=(0.0, 0.0, 0.9), target=(0.0, 0.0, 0.0), fov_y=40.0, width=8, height=8)
    scene = make_scene([], camera=cam, light_pos=(0.0, 0.9, 0.0), floor=False, sigma_s=0.32, sigma_a=0.08)
    return scene.__class__(**{**scene.__dict__, "medium": Medium((0.32,) * 3, (0.08,) * 3, Phase(), SLAB)})


def _lanes(n=LANES, seed=0):
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, n)
    origin = mi.Point3f(np.full(n, 0.1), np.full(n, -0.9), np.full(n, 0.2))
    return sampler, origin, mi.Vector3f(0.0, 1.0, 0.0)


def _mean_se(values) -> tuple[float, float]:
    v = np.asarray(values, np.float64)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v)))


def test_ratio_tracking_gives_the_slab_transmittance():
    medium = TrackedMedium(_slab_scene())
    assert medium.heterogeneous and medium.majorant == pytest.approx(3.0 * SIGMA_T)
    sampler, origin, up = _lanes()
    tr = medium.transmittance(origin, up, mi.Float(1.8), sampler)
    mean, se = _mean_se(tr[0])
    expected = math.exp(-SIGMA_T * SLAB_DEPTH)
    print("slab transmittance", mean, "±", se, "closed form", expected)
    assert abs(mean - expected) <= 4.0 * se and np.asarray(tr[0]).min() >= 0.0  # 4 SE: a false alarm ~1e-4
    # negative control: a tracker that ignores the grid (ρ ≡ 1) misses the closed form
    medium.density = lambda p, active=True: mi.Float(1.0)
    wrong, se = _mean_se(medium.transmittance(origin, up, mi.Float(1.8), sampler)[0])
    assert abs(wrong - expected) > 4.0 * se


def _flights(medium, seed):
    sampler, origin, up = _lanes(seed=seed)
    s, scattered, weight = medium.free_flight(origin, up, mi.Float(1.8), sampler)
    return np.asarray(s), np.asarray(scattered), np.asarray(weight[0])


def test_delta_tracking_draws_the_slab_free_flights():
    """A grey slab: P(a flight passes 1.8 m) = T(1.8), P(it scatters before 0.7 m) =
    1 − T(0.7), with T from the closed form; the weight at a scattering is the albedo."""
    medium = TrackedMedium(_slab_scene())
    s, scattered, weight = _flights(medium, 1)
    passes = ~scattered
    early = scattered & (s < 0.7)  # y < -0.2: the whole lower thin layer and 0.3 m of the thick one
    expected_pass = math.exp(-SIGMA_T * SLAB_DEPTH)
    expected_early = 1.0 - math.exp(-SIGMA_T * (0.5 * 0.4 + 3.0 * 0.3))
    for got, expected in ((passes, expected_pass), (early, expected_early)):
        mean, se = _mean_se(got)
        assert abs(mean - expected) <= 4.0 * se, (mean, se, expected)
    assert np.allclose(weight[scattered], 0.8, rtol=1e-5) and np.allclose(weight[passes], 1.0)
    # negative control: a majorant below the density (0.4 of it) draws the wrong flights
    medium.majorant *= 0.4
    s, scattered, _ = _flights(medium, 2)
    mean, se = _mean_se(~scattered)
    assert abs(mean - expected_pass) > 4.0 * se


def test_homogeneous_medium_keeps_its_closed_form():
    scene = make_scene([], floor=False)
    medium = TrackedMedium(scene)
    assert not medium.heterogeneous
    tr = medium.transmittance(mi.Point3f(0.0), mi.Vector3f(0, 1, 0), mi.Float(2.0), None)
    assert np.asarray(tr[0])[0] == np.float32(math.exp(-0.2 * 2.0))


# --- images (statistical: minutes; `make test-fast` skips them) --------------------------

W = H = 48
FOG = Density(field="height_fog", params=(("base", 0.2), ("density", 1.0), ("scale_height", 0.3)),
              resolution=(16, 16, 16))


def _fog_scene(density=FOG, sigma_scale=1.0):
    scene = make_scene([], light_pos=(0.3, 2.5, 0.2), light_dir=(-0.3, -2.0, -0.2), cutoff=35.0, beam=25.0,
                       camera=Camera(position=(0.0, 1.6, 3.0), target=(0.0, 0.3, 0.0), fov_y=40.0, width=W, height=H))
    s = sigma_scale
    medium = Medium((0.9 * s, 0.75 * s, 0.6 * s), (0.15 * s,) * 3, Phase("hg", 0.4), density)
    return scene.__class__(**{**scene.__dict__, "medium": medium})


def _camera_batches(scene, spp=32, seed0=0):
    mi_scene = mi.load_dict(to_mitsuba(scene))
    return integrator_batches(mi_scene, configure(SingleScatterIntegrator(), scene, mi_scene), spp, 8,
                              slice(0, 3), seed0)


@pytest.mark.slow
def test_single_scatter_matches_volpath_in_height_fog():
    scene = _fog_scene()
    mi_scene = mi.load_dict(to_mitsuba(scene))
    ours = _camera_batches(scene)
    volpath = mi.load_dict({"type": "volpath", "max_depth": 2})
    theirs = integrator_batches(mi_scene, volpath, 256, 8, slice(0, 3), seed0=100)
    assert agree(theirs, ours)
    # negative control: the homogeneous medium of the grid's mean density (a tracker that
    # ignores where the fog is) must fail the same test
    mean_density = float(density_grid(scene).values.mean())
    assert not agree(theirs, _camera_batches(_fog_scene(None, mean_density), seed0=300))


@pytest.mark.slow
def test_grid_of_ones_equals_the_homogeneous_medium():
    ones = Density(field="box", params=(("inside", 1.0), ("max", (1.0,) * 3), ("min", (-1.0,) * 3),
                                        ("outside", 1.0)), resolution=(4, 4, 4))
    homogeneous = _camera_batches(_fog_scene(None), seed0=0)
    assert agree(homogeneous, _camera_batches(_fog_scene(ones), seed0=100))
    off = Density(field="box", params=(("inside", 1.15), ("max", (1.0,) * 3), ("min", (-1.0,) * 3),
                                       ("outside", 1.15)), resolution=(4, 4, 4))
    assert not agree(homogeneous, _camera_batches(_fog_scene(off), seed0=200))  # a density 15% off is flagged


@pytest.mark.slow
def test_light_tracer_fog_matches_camera_fog_in_a_plume():
    """The light tracer's connections (ratio tracking along the beam and to the eye) against
    the camera integrator's fog (ratio tracking along the view ray and to the light): two
    estimators of one integral, with a glass sphere's shadow in a smoke plume."""
    plume = Density(field="plume", params=(("center", (0.0, 0.0, 0.0)), ("density", 4.0), ("frequency", 2.0),
                                           ("height", 2.2), ("octaves", 3), ("radius", 0.5), ("seed", 7),
                                           ("spread", 0.8)), resolution=(24, 24, 24))
    cam = Camera(position=(0.0, 1.2, 3.5), target=(0.0, 1.0, 0.0), fov_y=40.0, width=W, height=H)
    base = make_scene([(sphere_spec(0.35, (0.0, 1.5, 0.0), 12), 1.5, (0, 0, 0))], camera=cam, cutoff=25.0)
    scene = base.__class__(**{**base.__dict__, "medium": Medium((0.3,) * 3, (0.05,) * 3, Phase("hg", 0.3), plume)})
    mi_scene = mi.load_dict(to_mitsuba(scene))
    props = mi.Properties()
    props["mode"] = "fog"
    lt = integrator_batches(mi_scene, configure(VolumetricLightTracer(props), scene, mi_scene), 128, 8, slice(0, 3))
    ss = configure(SingleScatterIntegrator(), scene, mi_scene)
    camera_fog = integrator_batches(mi_scene, ss, 32, 8, slice(3, 6), seed0=100)
    assert agree(camera_fog, lt)
    assert lt[0].sum() > 0


@pytest.mark.slow
def test_fog_pixel_in_the_slab_matches_quadrature():
    """One pixel of the reference fog in a slab of two densities against the single-scattering
    integral by quadrature, σs and both legs' optical depths following the grid."""
    n = 16
    cam = Camera(position=(0.0, 1.2, 4.5), target=(0.0, 1.0, 0.0), fov_y=36.0, width=n, height=n)
    slab = Density(field="box", params=(("inside", 3.0), ("max", (20.0, 1.4, 20.0)), ("min", (-20.0, 0.8, -20.0)),
                                        ("outside", 0.5)), resolution=(4, 64, 4))
    base = make_scene([], camera=cam, sigma_s=0.3, sigma_a=0.05, cutoff=25.0, beam=15.0, g=0.4)
    scene = base.__class__(**{**base.__dict__, "medium": Medium((0.3,) * 3, (0.05,) * 3, Phase("hg", 0.4), slab)})
    mi_scene = mi.load_dict(to_mitsuba(scene))
    ss = configure(SingleScatterIntegrator(), scene, mi_scene)
    mean, var = integrator_batches(mi_scene, ss, 12288, 8, slice(3, 6))
    row, col = 10, 8
    eye = np.asarray(cam.position)
    grid = density_grid(scene)

    def radiance(px, py):
        d = pixel_ray(cam, px, py)
        return fog_quadrature(scene, eye, d, -eye[1] / d[1], grid)

    nodes, weights = np.polynomial.legendre.leggauss(3)
    expected = sum(wx * wy * radiance(col + 0.5 + 0.5 * x, row + 0.5 + 0.5 * y)
                   for x, wx in zip(nodes, weights) for y, wy in zip(nodes, weights)) / 4.0
    got = mean[row, col, 0]
    rel_noise = math.sqrt(var[row, col, 0]) / got
    print("slab pixel", got, "quadrature", expected, "noise", rel_noise)
    assert rel_noise < 0.0065  # 3 sigma of noise stays inside the 2% tolerance (ratio tracking's noise: 0.6%)
    assert got == pytest.approx(expected, rel=0.02), (got, expected)


def test_mitsuba_xml_carries_the_density_grid(tmp_path):
    """The exported XML (its .vol beside the meshes) loads in Mitsuba and renders what the
    scene dict renders, seed for seed (to the transforms' rounding); the homogeneous scene
    of the same coefficients does not."""
    from volcaustics.reference.render.export import export_xml

    scene = _fog_scene()
    scene = scene.__class__(**{**scene.__dict__, "camera": Camera(position=(0.0, 1.6, 3.0), target=(0.0, 0.3, 0.0),
                                                                  fov_y=40.0, width=16, height=16)})
    path = str(tmp_path / "fog.xml")
    export_xml(scene, path)
    assert len(list((tmp_path / "fog_meshes").glob("density-*.vol"))) == 1
    from_xml = np.asarray(mi.render(mi.load_file(path), seed=1, spp=64))
    from_dict = np.asarray(mi.render(mi.load_dict(to_mitsuba(scene)), seed=1, spp=64))
    # the XML's transforms are matrices written out, the dict's composed: 2e-5 relative measured
    assert np.allclose(from_xml, from_dict, rtol=1e-4, atol=1e-7) and from_xml.sum() > 0
    plain = scene.__class__(**{**scene.__dict__, "medium": Medium(scene.medium.sigma_s, scene.medium.sigma_a,
                                                                  scene.medium.phase)})
    assert not np.allclose(np.asarray(mi.render(mi.load_dict(to_mitsuba(plain)), seed=1, spp=64)), from_xml, rtol=0.05)
