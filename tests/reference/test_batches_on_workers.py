"""A reference's batches rendered as tasks on worker processes (local ones, and a Dask
cluster's) are added in the order the serial path renders them: its batch state (sums,
squares, per-batch totals, group sums), its layers and a continuation are the serial
render's bytes. Both sides render with one Dr.Jit thread: with more, the light tracer's
atomic splats add in a varying order (docs/decisions.md "Reference batches on workers")."""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
import pytest

from volcaustics.reference.cache import read_state
from volcaustics.reference.render import render_into_state, render_references
from volcaustics.reference.render.sources import InProcess
from volcaustics.reference.render.tasks import process_name, render_batch
from volcaustics.reference.request import resolve
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.measuring.pools.executors import open_pool
from volcaustics.scenes import load_builtin

SETTINGS = ReferenceSettings(photons=1 << 16, spp=8, batches=4, width=48, height=36)


@pytest.fixture
def one_thread():
    """This process renders with one Dr.Jit thread, as each of two workers on two cores does."""
    import drjit as dr

    from volcaustics.reference.mi_setup import mitsuba

    mitsuba()
    before = dr.thread_count()
    dr.set_thread_count(1)
    yield
    dr.set_thread_count(before)


def _jobs(batches: int) -> list:
    """sphere1 (two streams) and refocus with two scattering orders (three streams)."""
    settings = dataclasses.replace(SETTINGS, batches=batches)
    return [(load_builtin("sphere1"), settings, "caustic"),
            (load_builtin("refocus"), dataclasses.replace(settings, max_scatter=2), "caustic")]


def _digests(state: dict, layers: dict) -> dict:
    """SHA-256 of every array of a batch state and of every layer (the seconds left out)."""
    arrays = {**{k: v for k, v in state.items() if "seconds" not in k}, **{f"layer/{k}": v for k, v in layers.items()}}
    return {name: hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest() for name, a in arrays.items()}


def _stored(result) -> dict:
    return _digests(read_state(result.key, result.manifest), {**result.mean, **result.var})


@pytest.mark.slow  # two pools of two worker processes: about 40 s on 2 cores
@pytest.mark.parametrize("executor", [{"workers": 2}, {"dask": "local:2"}], ids=["local", "dask"])
def test_batches_rendered_on_workers_are_the_serial_render_byte_for_byte(executor, empty_cache, one_thread):
    with open_pool(**executor) as pool:
        first = render_references(_jobs(4), force=True, progress=False, pool=pool)
        continued = render_references(_jobs(6), progress=False, pool=pool)  # 2 more batches a stream, on the pool
    rendered_by = {name for result in (*first, *continued) for name in result.manifest["rendered_by"]}
    assert len(rendered_by) == 2 and process_name() not in rendered_by  # both workers, never this process
    on_workers = [_stored(result) for result in continued]
    serial = render_references(_jobs(4), force=True, progress=False)
    assert all(set(r.manifest["rendered_by"]) == {process_name()} for r in serial)
    here = [_stored(result) for result in render_references(_jobs(6), progress=False)]
    assert [len(d) for d in here] == [23, 58]  # every array of both states and all layers compared
    for pooled, serial_digests in zip(on_workers, here):
        assert pooled == serial_digests, [k for k in pooled if pooled[k] != serial_digests.get(k)]


class _Swapped(InProcess):
    """The serial path with the light stream's batches 0 and 1 read in each other's place."""

    def images(self, key, request, stream, index):
        swapped = {0: 1, 1: 0}.get(index, index) if stream == "light" else index
        return render_batch(key, request, stream, swapped)


def test_batches_merged_out_of_order_are_told_apart(empty_cache, one_thread):
    """Negative control of the comparison above: the same batches added in another order
    differ in the light stream's group sums (each batch goes to group index mod 8), while
    the camera stream's arrays stay the same bytes."""
    request = resolve(*_jobs(4)[0])
    key = "negative-control"
    digests = [_digests(render_into_state(request, key, None, source, progress=False)[0].arrays(), {})
               for source in (InProcess(), _Swapped())]
    differ = {name for name in digests[0] if digests[0][name] != digests[1][name]}
    assert "light/group/caustic" in differ and "light/total/caustic" in differ
    assert not {name for name in differ if name.startswith("camera/")}
