"""splat = beams: each photon's segment in the medium is a beam, estimated along every
camera ray that passes near it (splat/beam.*.glsl; Jarosz et al. 2011).

A lone beam in an open medium has a single-scattering answer by quadrature: the power
its points send to the eye, Σ L·Ω = ∫ Φ·σs·p·exp(−σt·s)·exp(−σt·d(s))/d(s)² ds. The beam's
image must give it, and the same beam drawn as dense point splats (the paper's 3D
Gaussians, whose sum along a line seen along a camera ray is exactly the beam's 1-D
kernel over sin θ) must give the same pixels. Negative controls: a beam without the
estimator's 1/sin θ and one without the transmittance to the camera are both flagged.
Through the whole pipeline, the tracer's beams carry the power its point photons
splat in expectation.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.shared import make_scene, pixel_solid_angles, sphere_spec
from volcaustics.approx import Renderer
from volcaustics.approx.camera_pass import CameraView
from volcaustics.approx.params import QUICK
from volcaustics.approx.splat import Splatter, beams_from_arrays, splat_commands, splats_from_arrays
from volcaustics.scenes.model import Camera

CAMERA = Camera(position=(0.0, 1.0, 4.0), target=(0.0, 1.0, 0.0), fov_y=36.0, width=160, height=160)
SIGMA = 0.03  # the kernel (m): 1.3 pixels at the beams' ~4 m, so the point-sampled kernel keeps its integral
# Oblique beams (sin θ from 0.4 to 0.9 against the view) well inside the view, none near the eye.
BEAMS = [((-0.9, 0.6, 0.8), (0.8, 0.3, -0.52), 1.4), ((0.6, 1.5, -0.5), (-0.3, -0.55, 0.78), 1.1),
         ((-0.2, 1.3, 1.0), (0.35, 0.1, -0.93), 1.6)]


def _draw(ctx, rows, *, beams: bool, sigma_t: float, sigma_s: float, controls: dict | None = None,
          radius: float = SIGMA, wall: float | None = None) -> tuple:
    """``rows`` (BEAM_DTYPE or SPLAT_DTYPE) splatted with kernel ``radius`` in an open medium
    of isotropic phase: the R channel (float64, rows bottom-up as GL draws them) and the pass's
    PassTimer (its fragments written and shaded); ``wall``: a G-buffer whose every pixel sees
    a diffuse surface at that distance (m), else none."""
    from volcaustics.approx.timing import PassTimer
    from volcaustics.scenes.formats import KIND_DIFFUSE

    scene = make_scene([], camera=CAMERA, sigma_s=sigma_s, sigma_a=sigma_t - sigma_s, floor=False)
    view = CameraView(CAMERA, CAMERA.width, CAMERA.height, far=100.0)
    splatter = Splatter(ctx, scene.medium, beams=beams, controls=controls)
    buf = ctx.buffer(rows.tobytes())
    pixels = CAMERA.width * CAMERA.height
    target = ctx.texture((CAMERA.width, CAMERA.height), 4, np.zeros(pixels * 4, "f4").tobytes(), dtype="f4")
    geometry = np.zeros((pixels, 4), "f4")  # G-buffer of an empty scene: no surface
    if wall is not None:
        geometry[:, 0], geometry[:, 1] = wall, KIND_DIFFUSE
    gbuffer = ctx.texture((CAMERA.width, CAMERA.height), 4, geometry.tobytes(), dtype="f4")
    timer = PassTimer(ctx, use_queries=False)
    with timer.measure("splat"):
        splatter.splat(buf, ctx.buffer(splat_commands(len(rows))), view, scene.medium, radius, gbuffer, target)
    timer.collect()  # the pass's counts, read once it is done
    image = np.frombuffer(target.read(), np.float32).reshape(CAMERA.height, CAMERA.width, 4)[..., 0].astype(np.float64)
    for r in (buf, target, gbuffer, splatter):
        r.release()
    return image, timer


def _image(ctx, rows, **kwargs) -> np.ndarray:
    """The image of :func:`_draw`."""
    return _draw(ctx, rows, **kwargs)[0]


def _beams(power: float = 0.2) -> np.ndarray:
    starts, dirs, lengths = zip(*BEAMS)
    dirs = np.asarray(dirs) / np.linalg.norm(dirs, axis=1)[:, None]
    return beams_from_arrays(starts, dirs, lengths, np.full((len(BEAMS), 3), power))


def _quadrature(rows: np.ndarray, sigma_t: float, sigma_s: float, n: int = 20000) -> float:
    """Σ over the beams of ∫ Φ·σs/(4π)·exp(−σt·s)·exp(−σt·d)/d² ds (midpoint rule, float64)."""
    total = 0.0
    for row in rows:
        start, length, d, power = row["start_length"][:3], row["start_length"][3], row["dir"][:3], row["power"][0]
        s = (np.arange(n) + 0.5) / n * length
        dist = np.linalg.norm(start + s[:, None] * d - np.asarray(CAMERA.position), axis=1)
        total += float(np.sum(power * sigma_s / (4 * math.pi) * np.exp(-sigma_t * (s + dist)) / dist**2) * length / n)
    return total


def test_a_beams_image_carries_its_single_scattering_to_the_eye(ctx):
    """Three oblique beams (σt = 0.5/m, so the transmittance to the camera is about e^−2):
    Σ L·Ω equals the quadrature to 0.5% (the kernel's truncation is renormalised; what is
    left is second order in σt·σ/sin θ, the transmittance's curvature across the kernel,
    0.1–0.4% for sin θ = 0.3 in float64 at 160 and 640 pixels alike). Without 1/sin θ
    the image loses the third or more of it an oblique beam needs; without the
    transmittance to the camera it gains the e^2 it should lose."""
    sigma_t, sigma_s = 0.5, 0.3
    rows = _beams()
    _, omega = pixel_solid_angles(CAMERA.fov_y, CAMERA.width)
    expected = _quadrature(rows, sigma_t, sigma_s)
    got = float((_image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s) * omega).sum())
    assert got == pytest.approx(expected, rel=5e-3)
    no_sine = float((_image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s,
                           controls={"BEAM_NO_SINE": 1}) * omega).sum())
    assert no_sine < 0.85 * expected
    no_camera = float((_image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s,
                             controls={"BEAM_NO_CAMERA_TRANSMITTANCE": 1}) * omega).sum())
    assert no_camera > 3.0 * expected


def _dense_points(rows: np.ndarray, sigma_t: float) -> np.ndarray:
    """Each beam as 2000 point splats per metre, each carrying Φ·exp(−σt·s)·σt·Δs (the splat
    weight σs/σt then gives the beam's scattering per metre)."""
    points = []
    for row in rows:
        start, length, d, power = row["start_length"][:3], row["start_length"][3], row["dir"][:3], row["power"][0]
        n = int(2000 * length)
        s = (np.arange(n) + 0.5) / n * length
        each = power * np.exp(-sigma_t * s) * sigma_t * length / n
        points.append(splats_from_arrays(start + s[:, None] * d, np.tile(d, (n, 1)), np.repeat(each[:, None], 3, 1)))
    return np.concatenate(points)


def test_a_beam_is_its_dense_point_splats_pixel_by_pixel(ctx):
    """Each beam as 2000 point splats per metre (spacing 0.5 mm ≪ σ), each carrying
    Φ·exp(−σt·s)·σ̄·Δs so that the splat weight σs/σ̄ gives the beam's scattering per
    metre: a row of 3D Gaussians seen along a pixel ray sums to the beam's 1-D kernel
    over sin θ, its ends included (beam.frag.glsl). The images agree to 1% relative L2
    (the transmittances are taken at the points' centres and at the beam's closest
    approach: second order in σt·σ/sin θ; measured below 1%). The beam without 1/sin θ
    is flagged the same way."""
    sigma_t, sigma_s = 0.3, 0.3
    rows = _beams()
    beam_image = _image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s)
    point_image = _image(ctx, _dense_points(rows, sigma_t), beams=False, sigma_t=sigma_t, sigma_s=sigma_s)

    def distance(image):
        return float(np.linalg.norm(image - point_image) / np.linalg.norm(point_image))

    assert distance(beam_image) < 0.01
    no_sine = _image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, controls={"BEAM_NO_SINE": 1})
    assert distance(no_sine) > 0.1


def test_a_beam_meeting_a_surface_counts_its_part_in_front_as_its_points_do(ctx):
    """A beam seen at a small angle is estimated where it passes closest to a pixel ray, a
    point that may lie behind the surface the ray meets while the beam's points near the
    ray are in front (a beam leaving a visible surface towards the eye: the glow around a
    highlight in a forward-scattering medium). A wall at 4 m: a beam leaving it towards
    the eye at sin θ ≈ 0.1, one crossing it at sin θ ≈ 0.3 and one behind it. The beams
    count the part of each in front of the wall along each pixel ray, as the dense point
    splats' depth tests do: the images agree to 3% relative L2 (the beam's cut is sharp
    where each point's Gaussian is cut at the wall along the ray; measured 1.1%). The
    negative control: the closest approach's own depth test (BEAM_CLOSEST_DEPTH, the
    estimator before the cut) is 10% off and more (measured 17%; 4% of the energy)."""
    sigma_t, sigma_s = 0.3, 0.3
    eye = np.asarray(CAMERA.position)
    ahead = np.array([0.06, 0.03, -1.0]) / np.linalg.norm([0.06, 0.03, -1.0])
    back = -ahead + np.array([0.1, 0.0, 0.0])
    crossing = np.array([0.33, 0.1, 0.94])
    behind = np.array([-0.2, 0.1, -1.0])
    starts = [eye + 4.0 * ahead, eye + 4.5 * np.array([-0.1, -0.05, -1.0]) / np.linalg.norm([-0.1, -0.05, -1.0]),
              eye + 4.4 * behind / np.linalg.norm(behind)]
    dirs = np.array([back, crossing, (1.0, 0.0, 0.0)])
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    rows = beams_from_arrays(starts, dirs, [1.5, 1.2, 0.4], np.full((3, 3), 0.2))
    point_image = _image(ctx, _dense_points(rows, sigma_t), beams=False, sigma_t=sigma_t, sigma_s=sigma_s, wall=4.0)

    def distance(image):
        return float(np.linalg.norm(image - point_image) / np.linalg.norm(point_image))

    assert distance(_image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, wall=4.0)) < 0.03
    closest = _image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, wall=4.0,
                     controls={"BEAM_CLOSEST_DEPTH": 1})
    assert distance(closest) > 0.1


def test_a_beam_carrying_its_own_kernel_keeps_its_energy_however_narrow(ctx):
    """A beam whose row carries its σ (the decomposition's small kernel) has its 1-D kernel
    integrated over each pixel's area: a beam along an image row and an oblique one, at
    σ = 0.05 and 0.1 pixel and eight sub-pixel offsets across, keep Σ L·Ω within 1% of
    the quadrature (measured ≤ 0.5%: the ends, still point-sampled along the beam). The
    same beams point-sampled at the same σ (σ from splat_radius) are off by a third or
    more at some offset (a Gaussian of 0.1 pixel sampled per pixel sums to anything from
    0 to several times its integral)."""
    sigma_t = sigma_s = 0.1
    _, omega = pixel_solid_angles(CAMERA.fov_y, CAMERA.width)
    pixel = 4.0 * 2.0 * math.tan(math.radians(CAMERA.fov_y / 2)) / CAMERA.height  # a pixel's width at 4 m
    for fraction in (0.05, 0.1):
        sigma = fraction * pixel
        boxed, sampled = [], []
        for offset in np.arange(8) / 8:
            y = 1.0 + (0.3 + offset) * pixel
            starts, lengths = [(-1.0, y, 0.0), (-0.8, y - 0.5, 0.2)], [2.0, 1.2]
            dirs = [(1.0, 0.0, 0.0), (0.8, 0.6, 0.0)]
            power = np.full((2, 3), 0.2)
            own = beams_from_arrays(starts, dirs, lengths, power, sigma=[sigma, sigma])
            expected = _quadrature(own, sigma_t, sigma_s)
            for rows, out in ((own, boxed), (beams_from_arrays(starts, dirs, lengths, power), sampled)):
                image = _image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, radius=sigma)
                out.append(float((image * omega).sum()) / expected)
        assert np.abs(np.array(boxed) - 1.0).max() < 0.01, (fraction, boxed)
        assert np.abs(np.array(sampled) - 1.0).max() > 0.3, (fraction, sampled)


def _spread(image: np.ndarray, column: int, rows_m: np.ndarray) -> float:
    """The variance (m²) across a horizontal beam of one image column, rows at ``rows_m``."""
    weight = image[:, column]
    mean = float((weight * rows_m).sum() / weight.sum())
    return float((weight * rows_m**2).sum() / weight.sum()) - mean**2


def test_a_beam_whose_kernel_changes_along_it_draws_its_widths_and_keeps_its_energy(ctx):
    """beam_width = differential: a row carrying σ0 at its start and a rate along it
    (splat/beam_width.glsl). A beam across the view at 4 m, σ from 0.6 to 2.4 pixels: each
    column's spread across it is the kernel there, σ(s)² times the cut Gaussian's factor
    plus a pixel's box (1/12 px²), within 1% (the pixel grid, as for an adaptive splat;
    measured ≤ 0.1%), and Σ L·Ω is the quadrature's to 1% (the 1-D kernel keeps its
    integral at every s, the ends' Gaussians take the nearer end's σ; measured 0.01%).
    The negative control: the same row without its rate is drawn σ0 wide all along, so
    the far end's spread is flagged."""
    sigma_t = sigma_s = 0.1
    _, omega = pixel_solid_angles(CAMERA.fov_y, CAMERA.width)
    half = math.tan(math.radians(CAMERA.fov_y / 2))
    pixel = 4.0 * 2.0 * half / CAMERA.height
    sigma0, rate, length = 0.6 * pixel, 0.9 * pixel, 2.0  # σ(s) = σ0 + rate·s: 0.6 to 2.4 pixels
    y = 1.0 + 0.3 * pixel
    widening = beams_from_arrays([(-1.0, y, 0.0)], [(1.0, 0.0, 0.0)], [length], [(0.2, 0.2, 0.2)], sigma=[sigma0])
    widening["power"][:, 3] = rate
    radius = 2.0 * pixel  # the clamp [radius/16, 4·radius] holds the whole beam
    image = _image(ctx, widening, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, radius=radius)
    assert float((image * omega).sum()) == pytest.approx(_quadrature(widening, sigma_t, sigma_s), rel=1e-2)
    centres = ((np.arange(CAMERA.height) + 0.5) / CAMERA.height * 2 - 1) * half * 4.0 + 1.0  # rows at z = 0 (m)
    cut = 1 - 6 * math.exp(-4.5) / math.sqrt(2 * math.pi) / math.erf(3 / math.sqrt(2))
    constant = widening.copy()
    constant["power"][:, 3] = 0.0
    flat = _image(ctx, constant, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, radius=radius)
    for x in (-0.6, 0.0, 0.6):  # the columns over x (m) on the beam
        column = int((x / 4.0 / half + 1) / 2 * CAMERA.width)
        x_centre = ((column + 0.5) / CAMERA.width * 2 - 1) * half * 4.0
        sigma = sigma0 + rate * (x_centre + 1.0)
        expected = sigma**2 * cut + pixel**2 / 12
        assert _spread(image, column, centres) == pytest.approx(expected, rel=1e-2), x
    assert _spread(flat, column, centres) < 0.5 * expected  # the far column: σ0 wide, not σ(s)


def test_a_widening_beam_is_drawn_as_a_trapezoid_that_holds_its_kernels(ctx):
    """beam_width = differential: a beam whose σ grows along it (0.3 to 2.4 pixels, and one
    held at the clamp's 4·radius past its middle: a bound that is not a line) is drawn as a
    trapezoid whose edges bound every kernel between its ends (splat/beam.vert.glsl). It
    writes the image of the widest kernel's rectangle (BEAM_RECTANGLE: the control) to
    1e-4 of its peak in any pixel (the kernel's cut edge is 1% of its peak; the ends'
    frames, turned to the eye, twist the edges and lose up to 1.1e-5 there, 2e-6 of the
    image), and shades fewer fragments (measured 15% fewer: the second beam's clamp keeps
    its far end wide)."""
    half = math.tan(math.radians(CAMERA.fov_y / 2))
    pixel = 4.0 * 2.0 * half / CAMERA.height
    radius = 0.6 * pixel  # the clamp [radius/16, 4·radius]: 0.04 to 2.4 pixels
    rows = beams_from_arrays([(-1.0, 0.8, 0.0), (-1.2, 1.3, 0.3)], [(1.0, 0.0, 0.0), (0.9, 0.1, -0.3)], [2.0, 2.2],
                             np.full((2, 3), 0.2), sigma=[0.5 * pixel, 0.3 * pixel])
    rows["power"][:, 3] = [0.95 * pixel, 2.0 * pixel]  # σ per metre: the second reaches the clamp at 0.9 m
    out = {}
    for name, controls in (("trapezoid", None), ("rectangle", {"BEAM_RECTANGLE": 1})):
        image, timer = _draw(ctx, rows, beams=True, sigma_t=0.1, sigma_s=0.1, controls=controls, radius=radius)
        out[name] = (image, timer.shaded["splat"])
    (trapezoid, shaded), (rectangle, rectangle_shaded) = out["trapezoid"], out["rectangle"]
    assert rectangle.sum() > 0
    assert np.abs(trapezoid - rectangle).max() <= 1e-4 * rectangle.max()
    assert shaded < 0.9 * rectangle_shaded


def test_a_beam_pass_counts_the_fragments_it_shades_beside_those_it_writes(ctx):
    """The beam pass's time follows the fragments it shades (approx.invocations), most of
    them discarded; the written ones (samples passed) miss those. The same beams drawn
    in front of a wall and behind it (a G-buffer of a diffuse surface at 1 m: the
    negative control) shade the same fragments, while behind it they write none."""
    counts = {}
    for name, wall in (("open", None), ("walled", 1.0)):
        _, timer = _draw(ctx, _beams(), beams=True, sigma_t=0.5, sigma_s=0.3, wall=wall)
        counts[name] = (timer.fragments["splat"], timer.shaded.get("splat"))
    assert "GL_ARB_pipeline_statistics_query" in ctx.extensions  # Mesa and NVIDIA have it: not optional here
    (open_written, open_shaded), (walled_written, walled_shaded) = counts["open"], counts["walled"]
    assert open_shaded > open_written > 0
    assert walled_written == 0 and walled_shaded == open_shaded


@pytest.mark.slow  # statistical: 32 seeds of point photons (7.5 s of the fast suite's 3 min)
def test_the_tracers_beams_carry_the_power_its_photons_splat(ctx):
    """A glass sphere under the spot above a floor: the frame's caustic with splat = beams
    (one segment per step, no free flight) and the mean caustic of 32 seeds of point
    photons traced 16 steps (so that truncation leaves < 0.1% in the medium) agree: the
    image totals within 4 standard errors of the points' mean (from their spread over
    the seeds, 0.3%) plus 0.3% (beams and points differ at second order in σt·σ/sin θ,
    test above; measured 0.6% apart, 1.7 SE), and per pixel to 4% relative L2 after a
    4×4 box (measured 1.5%: the points' own noise). The point frames differ by seed, the beams
    frame does not (no free flights)."""
    scene = make_scene([(sphere_spec(0.4, (0.0, 1.6, 0.0), 32), 1.5, (0.0, 0.0, 0.0))], cutoff=25.0, sigma_s=0.3,
                       width=96, height=96)
    base = dataclasses.replace(QUICK, photon_res=128, light_res=256, width=96, height=96, splat_radius=0.03)
    renderer = Renderer(scene)
    try:
        beams = renderer.render(scene, dataclasses.replace(base, splat="beams", steps=3), keep_records=False)
        again = renderer.render(scene, dataclasses.replace(base, splat="beams", steps=3, seed=7), keep_records=False)
        points = np.array([renderer.render(scene, dataclasses.replace(base, steps=16, seed=s), keep_records=False)
                           .images["caustic"][..., 0] for s in range(32)], np.float64)
    finally:
        renderer.release()
    b = beams.images["caustic"][..., 0].astype(np.float64)
    p = points.mean(axis=0)
    totals = points.sum(axis=(1, 2))
    se = totals.std(ddof=1) / np.sqrt(len(totals))
    assert b.sum() > 0
    assert abs(b.sum() - p.sum()) < 4 * se + 3e-3 * p.sum()
    np.testing.assert_array_equal(beams.images["caustic"], again.images["caustic"])

    def box(image, k=4):
        h, w = image.shape[0] // k * k, image.shape[1] // k * k
        return image[:h, :w].reshape(h // k, k, w // k, k).sum(axis=(1, 3))

    assert np.linalg.norm(box(b) - box(p)) / np.linalg.norm(box(p)) < 0.04


# Beams 2–3.3 m from the eye towards the image's corners, and (WIDE_PASSING) one that passes
# the camera and crosses its plane, and one across the view beside it.
WIDE = [((-0.9, 1.5, 2.0), (0.4, -0.1, -1.0), 1.0), ((0.8, 0.4, 1.5), (-0.2, 0.5, -1.0), 0.8),
        ((-0.5, 0.3, 1.0), (1.0, 0.2, 0.3), 0.6), ((0.6, 1.6, 2.2), (0.1, 0.6, 0.2), 0.5)]
WIDE_PASSING = [((1.5, 1.0, 6.0), (-0.3, 0.0, -1.0), 5.0), ((-3.0, 0.8, 3.5), (1.0, 0.1, 0.05), 6.0)]


def _rows(beams) -> np.ndarray:
    starts, dirs, lengths = zip(*beams)
    dirs = np.asarray(dirs) / np.linalg.norm(dirs, axis=1)[:, None]
    return beams_from_arrays(starts, dirs, lengths, np.full((len(beams), 3), 0.2))


def test_a_wide_beam_is_drawn_whole_and_keeps_its_energy_against_points(ctx):
    """A beam's quad holds every pixel whose ray its estimate reaches, however wide its
    kernel (splat/beam.vert.glsl: four planes through the eye, drawn as directions): at
    σ from 3 mm to 5 m, with beams near the image's corners, one crossing the camera's
    plane beside it and one across the view 3 m off, the image equals the one drawn over
    the whole image (BEAM_FULLSCREEN: every pixel shaded), pixel by pixel. Against the
    beams as dense point splats of the same σ (σt = 0.01/m: no transmittance between the
    estimators): where no kernel holds the eye (3σ < 1.99 m, the nearest beam), Σ L·Ω
    agrees to 2% (measured ≤ 1.1% at σ = 0.6 m: a point's kernel is cut to a disc, a
    beam's to a band, and wide kernels spill past the image's edges in different shapes);
    where kernels hold the eye (σ = 2 and 5 m) the beams keep at least the points' (a
    point's Gaussian loses its part behind the eye along each ray, a beam's estimate keeps
    it: measured 1.12× and 1.44×). The world-space quads lost such beams whole (Σ 0 at
    σ = 2 m: their corners fell behind the camera)."""
    sigma_t = sigma_s = 0.01
    _, omega = pixel_solid_angles(CAMERA.fov_y, CAMERA.width)
    rows = _rows(WIDE)
    points = _dense_points(rows, sigma_t)
    for sigma in (0.003, 0.03, 0.3, 0.6, 2.0, 5.0):
        for drawn in (rows, _rows(WIDE + WIDE_PASSING)):
            image = _image(ctx, drawn, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, radius=sigma)
            whole = _image(ctx, drawn, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, radius=sigma,
                           controls={"BEAM_FULLSCREEN": 1})
            np.testing.assert_array_equal(image, whole, err_msg=f"σ = {sigma} m")
        beams_total = float((_image(ctx, rows, beams=True, sigma_t=sigma_t, sigma_s=sigma_s, radius=sigma)
                             * omega).sum())
        points_total = float((_image(ctx, points, beams=False, sigma_t=sigma_t, sigma_s=sigma_s, radius=sigma)
                              * omega).sum())
        if 3 * sigma < 1.99:
            assert beams_total == pytest.approx(points_total, rel=0.02), sigma
        else:
            assert beams_total >= 0.98 * points_total > 0, sigma


def _toward_eye(target, angle_deg: float, sign: float, length: float):
    """A beam ending (or starting) at ``target`` at ``angle_deg`` to the line from the eye,
    pointing away from the eye (sign 1) or towards it (−1)."""
    target, eye = np.asarray(target), np.asarray(CAMERA.position)
    view = (target - eye) / np.linalg.norm(target - eye)
    across = np.cross(view, (0.0, 1.0, 0.0))
    across /= np.linalg.norm(across)
    a = math.radians(angle_deg)
    d = sign * (math.cos(a) * view + math.sin(a) * across)
    start = target if sign > 0 else target - d * length
    return tuple(start), tuple(d), length


# Beams seen nearly end-on, within 0–10° of the view (where the rays past an end reach up to
# √2·R there, and where one end's cone holds the other's: splat/beam.vert.glsl end_reach,
# beam_planes), pointing away from the eye and towards it.
END_ON = [_toward_eye((0.3, 1.2, 1.0), angle, sign, 1.2) for angle in (0.0, 0.5, 2.0, 5.0, 10.0)
          for sign in (1.0, -1.0)]


def test_a_beam_seen_end_on_is_drawn_whole(ctx):
    """Beams within 10° of the view, both ways, at σ from 3 mm to 0.3 m: the image equals
    the one drawn over the whole image (BEAM_FULLSCREEN), pixel by pixel, so the quad's
    caps past the ends (c·R, from the beam's angle to the view) and the pyramid around an
    end-on beam's cone leave out no pixel the estimate reaches; and the end-on beams are not
    drawn over the whole image (their quads shade fewer fragments than the control's)."""
    rows = _rows(END_ON)
    for sigma in (0.003, 0.03, 0.3):
        image, timer = _draw(ctx, rows, beams=True, sigma_t=0.01, sigma_s=0.01, radius=sigma)
        whole, whole_timer = _draw(ctx, rows, beams=True, sigma_t=0.01, sigma_s=0.01, radius=sigma,
                                   controls={"BEAM_FULLSCREEN": 1})
        assert image.sum() > 0
        np.testing.assert_array_equal(image, whole, err_msg=f"σ = {sigma} m")
        if sigma < 0.3 and timer.shaded.get("splat") is not None:  # counted where the driver has the query
            assert timer.shaded["splat"] < 0.5 * whole_timer.shaded["splat"], sigma
