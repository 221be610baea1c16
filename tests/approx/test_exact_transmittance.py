"""The decomposition's exact-transmittance controls (``approx.controls``: EXACT_MARCH,
EXACT_EYE) change what their term says and nothing else: in smoke's plume the frame with
the march exact keeps every photon where it was (the march draws no random numbers) and
only its power moves, by more at 2 march steps than at 64; the splats' transmittance to the
eye from an exact integral moves the caustic by more with a coarse camera volume than with
a fine one. A homogeneous medium has neither: the controls leave its frame bit for bit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.shared import media_renderer
from volcaustics.approx import Renderer, medium_volumes
from volcaustics.approx.params import QUICK
from volcaustics.approx.splat import record_splats, splatted
from volcaustics.scenes import load_builtin

SIZE = 64


@pytest.fixture(scope="module")
def smoke(gl_context):
    yield from media_renderer("smoke")


def _params(scene, **changes):
    return dataclasses.replace(QUICK, **{"width": SIZE, "height": SIZE, "photon_res": 96, **changes}).resolved(scene)


def _change(a: np.ndarray, b: np.ndarray) -> float:
    """|Σ(b − a)| / Σ a over the caustic (all channels)."""
    return float(abs(b.sum() - a.sum()) / a.sum())


def test_the_exact_march_moves_powers_not_photons_and_less_with_more_steps(smoke):
    scene, renderer = smoke
    exact = renderer.variant({"EXACT_MARCH": 1})
    change = {}
    for steps in (2, 64):
        p = _params(scene, march_steps=steps)
        a, m = renderer.render(scene, p), exact.render(scene, p)
        for ra, rm in zip(a.records, m.records):
            np.testing.assert_array_equal(ra["end"], rm["end"])  # the same collisions
            np.testing.assert_array_equal(ra["status"], rm["status"])
        change[steps] = _change(a.images["caustic"], m.images["caustic"])
    print("caustic change with the march exact:", change)
    # measured 1.2e-2 at 2 steps, 1.0e-5 at 64: the march's midpoint error falls as 1/steps²
    assert change[2] > 1e-3 and change[64] < 0.1 * change[2]


def test_beams_exact_march_is_a_fine_march(smoke):
    """Beams under EXACT_MARCH take the depth along the beam from knots the vertex stage
    integrates (splat/beam_knots.glsl) and the rest from the fragment's knot: the frame is
    the one a march of 128 steps gives, whose midpoint error is ~(2/128)² of 2 steps' 1.2%
    (about 3e-6, measured 4e-6); 2 steps, the negative control, are flagged."""
    scene, renderer = smoke
    exact = renderer.variant({"EXACT_MARCH": 1})
    p = _params(scene, splat="beams", photon_res=48)  # beams: a quarter of the points' photons (the suite's time)
    knots = exact.render(scene, p).images["caustic"]
    assert knots.sum() > 0

    def apart(steps: int) -> float:
        marched = renderer.render(scene, dataclasses.replace(p, march_steps=steps)).images["caustic"]
        return float(np.abs(marched - knots).sum() / knots.sum())

    fine, coarse = apart(128), apart(2)
    print("beams, exact march against 128 and 2 march steps:", fine, coarse)
    assert fine < 1e-4 < 1e-3 < coarse


def test_the_exact_eye_moves_the_caustic_less_with_a_finer_camera_volume(smoke):
    scene, renderer = smoke
    exact = renderer.variant({"EXACT_EYE": 1})
    change = {}
    for res, slices in ((8, 4), (256, 128)):
        p = _params(scene, camera_volume_res=res, camera_volume_slices=slices)
        frame = renderer.render(scene, p)
        collided = np.concatenate([r[splatted(r, p)] for r in frame.records])
        assert len(collided) > 100
        splats = record_splats(collided, p.splat)
        volume, direct = (r.splat(splats, scene, p) for r in (renderer, exact))
        change[res] = _change(volume, direct)
    print("caustic change with the eye's transmittance exact:", change)
    assert change[8] > 1e-3 and change[256] < 0.1 * change[8]  # measured 0.15 and 1.7e-4


@pytest.fixture(scope="module")
def small_beams(smoke):
    """(rows, params, image): smoke's beams of a 64² frame carrying a small σ of their own
    (as E_∞,s's do, integrated over each pixel), and their image with the eye exact."""
    scene, renderer = smoke
    p = _params(scene, splat="beams", photon_res=48)
    frame = renderer.render(scene, p)
    rows = record_splats(np.concatenate([r[splatted(r, p)] for r in frame.records]), p.splat)
    rows["dir"][:, 3] = np.float32(2e-3)
    return rows, p, renderer.variant({"EXACT_EYE": 1}).splat(rows, scene, p)


def _apart(image: np.ndarray, expected: np.ndarray) -> float:
    return float(np.abs(image - expected).sum() / expected.sum())


def test_beams_exact_eye_from_knots_is_the_walk_from_the_eye(smoke, small_beams, monkeypatch):
    """Beams under EXACT_EYE take the depth to the eye from knots along every pixel's ray
    (splat/eye_knots.glsl) and walk only from the knot before their point: the image one
    knot per pixel gives (the whole walk from the eye), to float32 rounding (measured
    6e-8 of the caustic; the knots' count follows the view's pixels,
    ``approx.medium_volumes.eye_knot_count``); a coarse camera volume, the negative
    control, is flagged."""
    scene, renderer = smoke
    rows, p, knots = small_beams
    assert medium_volumes.eye_knot_count(p.width, p.height) == medium_volumes.EYE_KNOTS_MAX > 1
    coarse = renderer.splat(rows, scene, dataclasses.replace(p, camera_volume_res=8, camera_volume_slices=4))
    monkeypatch.setattr(medium_volumes, "EYE_KNOTS_MAX", 1)
    walked = renderer.variant({"EXACT_EYE": 1}).splat(rows, scene, p)
    apart = {"walked": _apart(walked, knots), "coarse": _apart(coarse, knots)}
    print("beams' exact eye from knots against the walk and a coarse camera volume:", apart)
    assert apart["walked"] < 1e-5 < 1e-3 < apart["coarse"]


def test_beams_eye_knots_follow_the_view(smoke, small_beams, monkeypatch):
    """The eye knots are made again when the camera turns and when it comes back: a turned
    camera's image is the one its own knots of another count give (knots left from the
    first view would be off by far more), and the first view's image comes back bit for bit."""
    scene, renderer = smoke
    rows, p, first = small_beams
    eye = renderer.variant({"EXACT_EYE": 1})
    # the camera turned (its position, and with it the medium's box and grid, kept)
    moved = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, target=tuple(np.add(scene.camera.target, (0.15, 0.1, 0.0)))))
    knots = eye.splat(rows, moved, p)
    np.testing.assert_array_equal(eye.splat(rows, scene, p), first)
    monkeypatch.setattr(medium_volumes, "EYE_KNOTS_MAX", medium_volumes.EYE_KNOTS_MAX - 1)  # made again
    assert _apart(knots, eye.splat(rows, moved, p)) < 1e-5  # float32 rounding, as above (stale knots: 6e-2)


def test_a_homogeneous_frame_is_the_same_under_the_controls(gl_context):
    scene = load_builtin("sphere1")
    renderer = Renderer(scene)
    try:
        exact = renderer.variant({"EXACT_MARCH": 1, "EXACT_EYE": 1})
        p = _params(scene)
        a, b = renderer.render(scene, p), exact.render(scene, p)
    finally:
        renderer.release()
    for name in ("caustic", "fog", "direct"):
        np.testing.assert_array_equal(a.images[name], b.images[name])
