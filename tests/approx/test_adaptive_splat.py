"""Adaptive splats: each photon's kernel from its ray differential.

The footprint is checked against paraxial optics through one refraction (a sphere's
focal spread), the splat kernel against its integral for any width, and `fixed` against
the paper's program bit for bit (the differential code is compiled only for `adaptive`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.shared import make_scene, pixel_solid_angles, sphere_spec
from volcaustics.approx import ApproxParams, Renderer, render
from volcaustics.approx.camera_pass import CameraView
from volcaustics.approx.geometry import SceneGeometry
from volcaustics.approx.layers import BOTH, LightMapRenderer
from volcaustics.approx.light import LightFrustum
from volcaustics.approx.splat import Splatter, splat_commands, splats_from_arrays
from volcaustics.approx.trace import PhotonTracer, read_photons
from volcaustics.scenes.bounds import medium_bounds
from volcaustics.scenes.formats import DIFFERENTIAL_DTYPE, STATUS_SURFACE
from volcaustics.scenes.model import Camera

SMALL = ApproxParams(photon_res=128, light_res=256, width=64, height=64, fog_steps=32, splat_radius=0.03)


@pytest.mark.parametrize("radius,dist,ior", [(0.4, 1.8, 1.5), (0.3, 1.2, 1.8)])
def test_the_footprint_through_one_refraction_is_the_spheres_focal_spread(ctx, radius, dist, ior):
    """A point light at distance u above a glass sphere's top (radius R, index n): the
    photons' rays spread by s = 2·tan(cutoff)/N per metre, so at the surface w = s·u;
    the refracting surface (Gaussian optics: 1/u + n/v = (n − 1)/R) images the light at
    v = n·u·R/((n − 1)·u − R) inside the glass, so the pencil's width changes at the rate
    s' = −w/v = s·(1/n − (n − 1)·u/(n·R)). The near-axis photons' differentials after
    emission and their first refraction must say so. Tolerance 3%: the curvature comes
    from the map's interpolated normals of a 48-subdivision sphere, one texel apart."""
    centre_y = 3.0 - dist
    scene = make_scene([(sphere_spec(radius, (0, centre_y, 0), 48), ior, (0, 0, 0))], cutoff=30.0, beam=28.0,
                       sigma_s=0.0)
    res = 256
    params = dataclasses.replace(SMALL, photon_res=res, splat="adaptive")
    geo = SceneGeometry.upload(ctx, scene)
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    emission_map = LightMapRenderer(ctx, geo).render_light_map(frustum, res, facing=BOTH)
    tracer = PhotonTracer(ctx, params)
    buf = tracer.emit_photons(scene, frustum, emission_map, res, seed=1)
    photons = read_photons(buf, res * res)
    diff = np.frombuffer(tracer.differentials.read(), DIFFERENTIAL_DTYPE)
    alive = photons["dir"][:, 3] == STATUS_SURFACE
    pos = photons["pos"][alive, :3]
    near_axis = np.hypot(pos[:, 0], pos[:, 2]) < 0.05 * radius
    assert near_axis.sum() >= 4
    u = dist - radius
    s = 2 * frustum.tan_half / res
    expected = s * (1 / ior - (ior - 1) * u / (ior * radius))
    w, rate = diff["footprint"][alive][near_axis], diff["rate"][alive][near_axis]
    assert np.median(w) == pytest.approx(s * u, rel=3e-3)  # the grid's spread over u (cos² ≈ 1 on the axis)
    assert np.median(rate) == pytest.approx(expected, rel=3e-2)
    assert expected < 0  # negative control: the sphere focuses; a flat surface would give s/n > 0
    for x in (buf, emission_map, tracer):
        x.release()


def test_fixed_splats_carry_no_kernel_and_no_differential(ctx):
    """splat = fixed is the paper's program: no differential is computed (zeros) and the
    compacted splats carry no kernel of their own (0: splat_radius)."""
    scene = make_scene([(sphere_spec(0.4, (0, 1.2, 0), 24), 1.5, (0, 0, 0))], cutoff=25.0)
    frame = render(scene, dataclasses.replace(SMALL, photon_res=64, light_res=64))
    adaptive = render(scene, dataclasses.replace(SMALL, photon_res=64, light_res=64, splat="adaptive"))
    for name in ("fog", "direct", "mask_specular"):
        np.testing.assert_array_equal(frame.images[name], adaptive.images[name])
    assert not np.array_equal(frame.images["caustic"], adaptive.images["caustic"])
    fixed_records = np.concatenate(frame.records)
    adaptive_records = np.concatenate(adaptive.records)
    for name in ("end", "power", "status"):  # the same photons: only the kernels differ
        np.testing.assert_array_equal(fixed_records[name], adaptive_records[name])


@pytest.mark.parametrize("sigma_px", [0.05, 0.25, 1.0, 3.0, 12.0])
def test_a_splat_of_any_width_keeps_its_integral(ctx, sigma_px):
    """The kernel of one splat, of a width given per splat from a twentieth of a pixel to
    12 pixels, integrated over each pixel's area: the image integral Σ L·Ω is the point
    photon's Φ/(4π)·exp(−σt z)/z² for any width (the paper's 3D kernel adds σ²/z²,
    test_frame). 1e-4: the pixel masses of a Gaussian sum to 1 to the erf approximation
    (1.5e-7 per edge), cut to ±3σ per axis and renormalised, so nothing is left out;
    pixel_angle²·cos³θ is each pixel's solid angle to O(pixel²) ≈ 1e-8."""
    z, sigma_t, power = 3.0, 0.1, 2.0
    cam = Camera(position=(0.0, 1.0, z), target=(0.0, 1.0, 0.0), fov_y=20.0, width=160, height=160)
    scene = make_scene([], camera=cam, sigma_s=sigma_t, sigma_a=0.0, floor=False)
    view = CameraView(cam, cam.width, cam.height, far=100.0)
    pixel = z * 2 * math.tan(math.radians(cam.fov_y) / 2) / cam.height  # a pixel's width at the splat
    sigma = sigma_px * pixel
    splatter = Splatter(ctx, scene.medium, adaptive=True)
    centre = [0.3 * pixel, 1.0 + 0.2 * pixel, 0.0]  # off the pixel grid's centres and edges
    raw = splats_from_arrays(end=[centre], direction=[[0.0, -1.0, 0.0]], power=[[power] * 3], sigma=[sigma])
    records = ctx.buffer(raw.tobytes())
    target = ctx.texture((cam.width, cam.height), 4, dtype="f4")
    empty = ctx.texture((cam.width, cam.height), 4, dtype="f4")
    query = ctx.query(samples=True)
    with query:
        commands = ctx.buffer(splat_commands(1))
        splatter.splat(records, commands, view, scene.medium, 1.0, empty, target)  # a 1 m splat_radius: never used
    # the billboard reaches the kernel's ±3σ square and a pixel, no further (the splat's cost)
    assert query.samples <= (2 * (3 * sigma_px + 1) + 1) ** 2
    image = np.frombuffer(target.read(), np.float32).reshape(cam.height, cam.width, 4)[..., 0].astype(np.float64)
    edges, omega = pixel_solid_angles(cam.fov_y, cam.width)  # exact, of the image plane at unit distance
    expected = power / (4 * math.pi) * math.exp(-sigma_t * z) / z**2
    assert float((image * omega).sum()) == pytest.approx(expected, rel=1e-4)
    # and it is this splat's width that was drawn: across the splat plane the image's
    # spread is the variance of a Gaussian cut at ±3σ (σ²·(1 − 6φ(3)/erf(3/√2)), the
    # kernel's square) plus a pixel's box (1/12 px²), its mean the centre; 2%: the pixel
    # grid (from a pixel wide; narrower kernels fall in one to four pixels, their spread the grid's)
    centres = (edges[:-1] + edges[1:]) / 2 * z
    weight = image.sum(axis=0)
    mean = float((weight * centres).sum() / weight.sum())
    if sigma_px >= 1.0:
        assert mean == pytest.approx(centre[0], abs=0.02 * pixel)
        spread = float((weight * centres**2).sum() / weight.sum()) - mean**2
        cut = 1 - 6 * math.exp(-4.5) / math.sqrt(2 * math.pi) / math.erf(3 / math.sqrt(2))
        assert spread == pytest.approx(sigma**2 * cut + pixel**2 / 12, rel=2e-2)
    for x in (records, target, empty):
        x.release()


def test_the_footprint_through_a_ball_lens_follows_paraxial_optics(ctx):
    """The trace carries the differential on: along the axis of a glass sphere under the
    light, the footprint at the exit (step 1's end) is w + s'·2R, with s' from the entry
    (test above); after the exit the pencil converges at the ball lens's back focus, so
    the rate there is s'' = n·s' − (n − 1)·w_exit/R (Coddington at the concave-from-inside
    exit). Checked on step 2's records: a second sphere far below is hit at distance t2,
    where the footprint is w_exit + s''·t2. 3%: curvature from one texel's neighbours."""
    radius, dist, ior, res = 0.4, 1.6, 1.5, 256
    top = 3.0 - dist + radius  # the first sphere's top (light at y = 3)
    low_centre = top - 2 * radius - 1.5  # a second sphere 1.5 m below the first's bottom
    scene = make_scene([(sphere_spec(radius, (0, top - radius, 0), 48), ior, (0, 0, 0)),
                        (sphere_spec(0.5, (0, low_centre, 0), 48), ior, (0, 0, 0))],
                       cutoff=30.0, beam=28.0, sigma_s=0.0, floor=False)
    params = dataclasses.replace(SMALL, photon_res=res, light_res=1024, steps=2, splat="adaptive",
                                 fresnel="stochastic", seed=3)
    frame = render(scene, params)
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    s = 2 * frustum.tan_half / res
    u = 3.0 - top
    w0 = s * u
    s1 = s * (1 / ior - (ior - 1) * u / (ior * radius))
    w_exit = w0 + s1 * 2 * radius
    s2 = ior * s1 - (ior - 1) * w_exit / radius
    t2 = (top - 2 * radius) - (low_centre + 0.5)
    step1, step2 = frame.records
    axis1 = (np.hypot(step1["end"][:, 0], step1["end"][:, 2]) < 0.01) & (step1["status"] == STATUS_SURFACE)
    axis1 &= step1["end"][:, 1] < top - radius  # ended at the exit, refracted out (not reflected back)
    assert axis1.sum() >= 3
    assert np.median(step1["footprint"][axis1]) == pytest.approx(w_exit, rel=3e-2)
    axis2 = np.isin(step2["photon"], step1["photon"][axis1]) & (step2["status"] == STATUS_SURFACE)
    axis2 &= np.abs(step2["end"][:, 1] - (low_centre + 0.5)) < 0.01
    assert axis2.sum() >= 3
    assert np.median(step2["footprint"][axis2]) == pytest.approx(w_exit + s2 * t2, rel=3e-2)
    assert w_exit + s2 * t2 < 0  # negative control: past the focus the pencil has turned over


def test_a_beams_differential_is_its_photons_at_the_segments_start(ctx):
    """beam_width = differential: a beam's kernel comes from the photon's differential at
    its segment's start (the footprint there and its rate along it), which the records
    keep. Under a ball lens, the beam that leaves the exit (step 2) starts at w_exit with
    the converging rate s'' of Coddington's exit (test above), within 3% (curvature from
    one texel's neighbours). Negative control: with the differential not propagated
    through refraction (DIFFERENTIAL_UNPROPAGATED) the rate stays the grid's spread s > 0
    where the lens makes it negative."""
    radius, dist, ior, res = 0.4, 1.6, 1.5, 256
    top = 3.0 - dist + radius
    scene = make_scene([(sphere_spec(radius, (0, top - radius, 0), 48), ior, (0, 0, 0))], cutoff=30.0, beam=28.0,
                       sigma_s=0.1)
    params = dataclasses.replace(SMALL, photon_res=res, light_res=1024, steps=2, splat="beams",
                                 beam_width="differential", fresnel="stochastic", seed=3)
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    s = 2 * frustum.tan_half / res
    u = 3.0 - top
    s1 = s * (1 / ior - (ior - 1) * u / (ior * radius))
    w_exit = s * u + s1 * 2 * radius
    s2 = ior * s1 - (ior - 1) * w_exit / radius
    for controls in (None, {"DIFFERENTIAL_UNPROPAGATED": 1}):
        renderer = Renderer(scene, controls=controls)
        try:
            step1, step2 = renderer.render(scene, params).records
        finally:
            renderer.release()
        axis1 = (np.hypot(step1["end"][:, 0], step1["end"][:, 2]) < 0.01) & (step1["status"] == STATUS_SURFACE)
        axis1 &= step1["end"][:, 1] < top - radius  # ended at the exit, refracted out
        beams = np.isin(step2["photon"], step1["photon"][axis1]) & (step2["inside"] < 0)
        assert beams.sum() >= 3
        rate = float(np.median(step2["footprint_rate"][beams]))
        if controls is None:
            assert np.median(step2["footprint"][beams]) == pytest.approx(w_exit, rel=3e-2)
            assert rate == pytest.approx(s2, rel=3e-2)
            assert s2 < 0  # converging towards the back focus
        else:
            assert rate == pytest.approx(s, rel=3e-2)  # the grid's spread, never turned by the lens
