"""A heterogeneous medium's work is counted (``approx.cost``'s medium reads): the trace
shader counts every segment's march and delta tracking's tentative collisions, so twice the
march's samples add exactly march_steps per marched segment (the same photons: the march
draws no random numbers); the volumes' texels and the other passes' reads follow their
parameters; a homogeneous scene counts none, and a weight set that never priced a medium
refuses its frames instead of pricing the reads as free."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.shared import media_renderer
from volcaustics.approx import Renderer
from volcaustics.approx.cost import MEDIUM_PARTS, frame_cost
from volcaustics.approx.cost_model import WeightSet, predicted_frames, weight_sets
from volcaustics.approx.params import BEAMS, QUICK
from volcaustics.scenes import load_builtin
from volcaustics.scenes.formats import STATUS_COLLIDED, STATUS_SURFACE

SIZE = 64


@pytest.fixture(scope="module")
def fogbank(gl_context):
    yield from media_renderer("fogbank")


def _frame(setup, **changes):
    scene, renderer = setup
    p = dataclasses.replace(QUICK, **{"width": SIZE, "height": SIZE, "photon_res": 64, **changes}).resolved(scene)
    frame = renderer.render(scene, p, keep_records=True)
    return frame, p, frame_cost(frame.records, p, frame.work)


def test_the_trace_counts_each_marched_segment_and_each_tentative_collision(fogbank):
    (frame, p, four), (_, _, eight) = _frame(fogbank, march_steps=4), _frame(fogbank, march_steps=8)
    records = np.concatenate(frame.records)
    marched = int(np.count_nonzero((records["inside"] < 0)
                                   & np.isin(records["status"], (STATUS_SURFACE, STATUS_COLLIDED))))
    collided = int(np.count_nonzero(records["status"] == STATUS_COLLIDED))
    assert marched > 300 and collided > 100  # fogbank at 64² photons: 695 and a few hundred measured
    # the same photons at both (the march draws no random numbers): 4 more samples per marched segment
    assert eight["segments"] == four["segments"]
    assert eight["medium_reads_trace"] - four["medium_reads_trace"] == 4 * marched
    tentative = four["medium_reads_trace"] - 4 * marched
    assert tentative >= collided  # every collision is an accepted tentative one
    assert four["medium_reads_emission"] == 4 * four["photons"]
    assert four["medium_reads_volumes"] == (p.camera_volume_res**2 * p.camera_volume_slices
                                            + p.light_volume_res**2 * p.light_volume_slices)
    assert four["medium_reads_splat"] == 4 * four["splats"]  # a camera-volume read per quad corner
    assert four["medium_reads_fog"] == 3 * p.fog_steps * four["fragments_fog"]
    assert four["total"] == (four["map_reads"] + four["emission_reads"] + four["splats"] + four["density_reads"]
                             + sum(four[f"medium_reads_{n}"] for n in MEDIUM_PARTS))


def test_beams_count_their_march_in_every_shaded_fragment(fogbank):
    _, p, cost = _frame(fogbank, **{**BEAMS, "photon_res": 48})
    fragments = cost["shaded_splat"] if np.isfinite(cost["shaded_splat"]) else cost["fragments_splat"]
    assert fragments > 0 and cost["medium_reads_splat"] == (p.march_steps + 2) * fragments


def test_a_homogeneous_scene_counts_no_medium_reads(gl_context):
    scene = load_builtin("sphere1")
    renderer = Renderer(scene)
    try:
        p = dataclasses.replace(QUICK, width=SIZE, height=SIZE, photon_res=64).resolved(scene)
        frame = renderer.render(scene, p, keep_records=True)
    finally:
        renderer.release()
    cost = frame_cost(frame.records, p, frame.work)
    assert cost["medium_reads"] == 0 and all(cost[f"medium_reads_{n}"] == 0 for n in MEDIUM_PARTS)


def test_a_set_without_medium_weights_refuses_a_heterogeneous_frame(fogbank):
    _, p, cost = _frame(fogbank)
    sets = weight_sets()
    unaware = {name: WeightSet(ws.name, ws.unit, {k: {f: w for f, w in fw.items() if f != "medium_reads"}
                                                  for k, fw in ws.weights.items()}, ws.provenance)
               for name, ws in sets.items()}
    assert predicted_frames(cost, p, unaware) == {}  # negative control: the reads would be free
    homogeneous = {**cost, "medium_reads": 0}
    assert set(predicted_frames(homogeneous, p, unaware)) == {n for n, ws in sets.items() if ws.prices(p)}
    # a set that learnt the reads prices them: more reads, a longer predicted frame
    priced = {n: ws for n, ws in sets.items() if ws.media}
    assert {"llvmpipe", "paper_gpu"} <= set(priced)  # bench/cost_model.py --media fitted them
    more = {**cost, "medium_reads_trace": 2 * cost["medium_reads_trace"]}
    for name, ws in priced.items():
        assert ws.frame(more, p) > ws.frame(cost, p), name
