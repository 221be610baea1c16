"""``denoise = oidn``: Intel Open Image Denoise on a small frame's caustic and fog
layers, guided by the G-buffer; the layers it does not touch stay bit for bit, the
combined layer is recomposed, its time and pixels are reported beside the frame cost,
and a noisy caustic comes out closer to a many-seed mean."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from volcaustics.approx import Renderer
from volcaustics.approx.cost import frame_cost
from volcaustics.approx.denoise import DENOISED, unavailable
from volcaustics.approx.params import QUICK
from volcaustics.scenes import load_builtin

pytestmark = pytest.mark.skipif(unavailable() is not None, reason=str(unavailable()))


def _frames(**changes):
    scene = load_builtin("sphere1")
    params = dataclasses.replace(QUICK, photon_res=48, light_res=64, width=48, height=48, **changes)
    renderer = Renderer(scene)
    try:
        return [renderer.render(scene, dataclasses.replace(params, seed=s)) for s in range(12)], params.resolved(scene)
    finally:
        renderer.release()


def _relmse(a, r):
    return float(np.sum((a - r) ** 2) / np.sum(r**2))


def test_oidn_denoises_the_caustic_and_fog_and_reports_its_cost():
    plain, _ = _frames()
    denoised, params = _frames(denoise="oidn")
    truth = np.mean([f.images["caustic"] for f in plain], axis=0)  # 12 seeds' mean: far less noise than one frame
    for a, b in zip(plain, denoised):
        assert np.array_equal(a.images["direct"], b.images["direct"])
        assert np.allclose(b.images["combined"], b.images["caustic"] + b.images["fog"] + b.images["direct"])
        assert not np.array_equal(a.images["caustic"], b.images["caustic"])
        assert b.timings["denoise"] > 0 and "denoise" not in a.timings
        assert frame_cost(b.records, params)["denoised_pixels"] == len(DENOISED) * 48 * 48
        assert frame_cost(b.records, params)["total"] == frame_cost(a.records, dataclasses.replace(
            params, denoise="none"))["total"]  # beside the cost, never in it
    before = np.mean([_relmse(f.images["caustic"], truth) for f in plain])
    after = np.mean([_relmse(f.images["caustic"], truth) for f in denoised])
    assert after < before, (after, before)
