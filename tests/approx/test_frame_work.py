"""All the work of a frame is counted (``approx.cost``): fragments per raster pass
(GL samples-passed queries), photons launched and segments traced. A splat's fragments
grow with its kernel; a fixed kernel's fragments per splat do not move when only the
photon density changes (the negative control), a density kernel's do."""

from __future__ import annotations

import dataclasses

import pytest

from volcaustics.approx import Renderer
from volcaustics.approx.cost import FRAGMENT_PASSES, frame_cost
from volcaustics.approx.params import QUICK
from volcaustics.scenes import load_builtin

SIZE = 96


@pytest.fixture(scope="module")
def sphere1(gl_context):
    scene = load_builtin("sphere1")
    renderer = Renderer(scene)
    yield scene, renderer
    renderer.release()


def _cost(sphere1, **changes) -> dict:
    scene, renderer = sphere1
    p = dataclasses.replace(QUICK, **{"width": SIZE, "height": SIZE, "photon_res": 96, "light_res": 96, **changes})
    p = p.resolved(scene)
    frame = renderer.render(scene, p, keep_records=True)
    return frame_cost(frame.records, p, frame.work)


def test_every_raster_pass_counts_its_fragments_and_the_trace_its_photons(sphere1):
    cost = _cost(sphere1, splat="density")
    for name in FRAGMENT_PASSES:
        assert cost[f"fragments_{name}"] > 0, name
    assert cost["fragments_fog"] == cost["fragments_direct"] == SIZE * SIZE  # full-screen passes: one per pixel
    # one point per splat in the pre-pass, less those outside the view (clipped)
    assert 0.9 * cost["splats"] <= cost["fragments_density"] <= cost["splats"]
    assert 0 < cost["photons"] <= 96 * 96 and cost["photons"] <= cost["segments"] <= 4 * cost["photons"]
    fixed = _cost(sphere1)
    assert fixed["fragments_density"] == 0  # no pre-pass without density splats


def test_a_splats_fragments_grow_with_its_kernel(sphere1):
    """Fixed splats of radius r cover ∝ r² pixels (the splats themselves the same)."""
    counts = {r: _cost(sphere1, splat_radius=r) for r in (0.01, 0.02, 0.04)}
    assert counts[0.01]["splats"] == counts[0.04]["splats"]
    for small, large in ((0.01, 0.02), (0.02, 0.04)):
        ratio = counts[large]["fragments_splat"] / counts[small]["fragments_splat"]
        assert 2.5 < ratio < 4.5, (small, large, ratio)  # r² = 4, less the billboards cut by the image's edge


def test_fragments_per_splat_follow_the_photon_density_only_with_density_splats(sphere1):
    """4× the photons: a fixed kernel's fragments per splat stay (the negative control);
    density kernels narrow where the photons are denser, so theirs fall."""
    def per_splat(**changes):
        sparse, dense = (_cost(sphere1, photon_res=res, **changes) for res in (64, 128))
        return (dense["fragments_splat"] / dense["splats"]) / (sparse["fragments_splat"] / sparse["splats"])

    assert 0.9 < per_splat() < 1.1
    assert per_splat(splat="density", splat_neighbours=8) < 0.6


def test_the_trace_loop_is_counted_per_photon_and_in_lockstep(gl_context):
    """A subgroup runs until its longest search ends: its lockstep count (longest × size)
    is at least its photons' own lookups and at most 64× them (no subgroup is wider). On
    bunny a photon that misses the mesh stops searching early while its neighbours go on,
    so lockstep is well above the photons' own (measured 1.7× at 256²; without subgroups the
    shader counts the photons' own and this fails: the negative control)."""
    scene = load_builtin("bunny")
    renderer = Renderer(scene)
    try:
        p = dataclasses.replace(QUICK, width=SIZE, height=SIZE, photon_res=128, light_res=128).resolved(scene)
        frame = renderer.render(scene, p, keep_records=True)
    finally:
        renderer.release()
    cost = frame_cost(frame.records, p, frame.work)
    assert 0 < cost["lookups"] <= cost["lockstep_lookups"] <= 64 * cost["lookups"]
    assert cost["lockstep_lookups"] > 1.2 * cost["lookups"]
