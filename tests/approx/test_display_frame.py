"""The display frame (``Renderer.draw``) is the measured frame (``Renderer.render``) without
its reads: the same passes give the same image, bit for bit, frame after frame, and a
steady stream of display frames makes no GL object (docs/approx.md "A frame to draw and a
frame to measure"). Its calls are checked for stalls in test_display_frame_calls.py."""

import dataclasses

import numpy as np
import pytest

from tests.approx.display_configs import CONFIGS, SCENE
from volcaustics.approx.params import preset
from volcaustics.approx.renderer import Renderer
from volcaustics.scenes import resolve_scene


def _drawn(texture) -> np.ndarray:
    """A display frame's texture as the measured frame's layers are: H×W×3, row 0 at the top."""
    w, h = texture.size
    return np.frombuffer(texture.read(), np.float32).reshape(h, w, 4)[::-1, :, :3]


@pytest.fixture(scope="module")
def renderer(gl_context):
    r = Renderer(resolve_scene(SCENE), gl_context)
    yield r
    r.release()


@pytest.mark.parametrize("name", list(CONFIGS))
def test_draw_is_the_measured_frame_bit_for_bit(renderer, name):
    """The composed image ``draw`` leaves on the GPU equals ``render``'s ``combined`` layer
    bit for bit (both add the step images, then caustic + fog + direct, in float32 in one
    order), on its first frame, in the steady state, after another configuration drew into
    the kept resources, and with another seed; a steady-state display frame makes no GL
    object."""
    p = CONFIGS[name]
    scene = renderer.scene
    measured = renderer.render(scene, p).images["combined"]
    assert measured.sum() > 0
    assert np.array_equal(_drawn(renderer.draw(scene, p)), measured)
    renderer.draw(scene, p)
    made = renderer.pool.made
    assert np.array_equal(_drawn(renderer.draw(scene, p)), measured)
    assert renderer.pool.made == made  # steady state: every buffer and image is kept
    other = CONFIGS["beams" if name != "beams" else "paper"]
    renderer.draw(scene, other)
    assert np.array_equal(_drawn(renderer.draw(scene, p)), measured)
    seeded = dataclasses.replace(p, seed=p.seed + 1)
    drawn, again = _drawn(renderer.draw(scene, seeded)), renderer.render(scene, seeded).images["combined"]
    assert np.array_equal(drawn, again) and not np.array_equal(again, measured)


def test_a_frame_that_keeps_last_frames_splats_is_caught(ctx, renderer):
    """Negative control: with the STEP_IMAGES_KEPT control the step images are not cleared
    between frames, the fault kept resources invite; its second display frame differs from
    the measured frame of a clean renderer (last frame's splats are added again)."""
    p = CONFIGS["paper"]
    measured = renderer.render(renderer.scene, p).images["combined"]
    faulty = Renderer(resolve_scene(SCENE), ctx, controls={"STEP_IMAGES_KEPT": 1})
    try:
        faulty.draw(faulty.scene, p)
        second = _drawn(faulty.draw(faulty.scene, p))
        assert not np.array_equal(second, measured)
        assert second.sum() > measured.sum()
    finally:
        faulty.release()


def test_draw_refuses_what_needs_the_host(renderer):
    """A display frame has no host stage: OIDN, the temporal average and adaptive emission's
    slots are refused by name, not silently dropped or read back."""
    for change in ({"denoise": "oidn"}, {"temporal": "ema"}, {"emission": "adaptive"}):
        with pytest.raises(ValueError, match=next(iter(change))):
            renderer.draw(renderer.scene, preset("quick", **change))


def test_a_steady_measured_frame_makes_no_query(renderer, monkeypatch):
    """moderngl cannot delete a query, so the measured frame's (pass timers, light maps) are
    read after the frame and reused by the next: a stream of measured frames makes none
    after the first (each made about 50 before, never freed)."""
    p = CONFIGS["best"]
    renderer.render(renderer.scene, p, keep_records=False)
    made = []
    real = type(renderer.ctx).query
    monkeypatch.setattr(type(renderer.ctx), "query", lambda self, *a, **k: made.append(k) or real(self, *a, **k))
    for _ in range(2):
        renderer.render(renderer.scene, p, keep_records=False)
    assert made == []
