"""Damaged reference caches: every cached file is verified when read,
a damaged one is recomputed, never served or rendered from; a continued entry is
written into new files and switched to atomically."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from volcaustics.infra.imageio import read_exr, write_exr
from volcaustics.infra.storage import document_sha256, file_sha256
from volcaustics.reference import cache
from volcaustics.reference.render import render_reference
from volcaustics.reference.request import resolve
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.scenes import load_builtin

SETTINGS = ReferenceSettings(photons=100000, spp=8, batches=2, width=16, height=12)


def _manifest_path(empty_cache, key: str) -> Path:
    return empty_cache / "reference" / f"{key}.json"


@pytest.mark.parametrize("damage", ["another scene's mesh", "truncated", "garbage"])
def test_a_damaged_mitsuba_mesh_is_rewritten_never_rendered(empty_cache, damage):
    """The PLY files Mitsuba reads are named by content hash; one whose bytes are not
    that content (another scene's glass swapped in, a truncated or garbage file) is
    rewritten before Mitsuba reads it: `--force` renders the right glass (before: the
    wrong glass became ground truth, or Mitsuba raised on every later run)."""
    scene = load_builtin("refocus")
    first = render_reference(scene, SETTINGS, progress=False)
    other = next(iter(resolve(load_builtin("two_spheres"), SETTINGS).description.meshes.values()))
    plys = sorted((empty_cache / "mitsuba-meshes").glob("*.ply"))
    assert plys
    for ply in plys:
        data = ply.read_bytes()
        ply.write_bytes({"another scene's mesh": other, "truncated": data[: len(data) // 2],
                         "garbage": b"ply\n\0\xff garbage"}[damage])
    again = render_reference(scene, SETTINGS, force=True, progress=False)
    # the camera stream is deterministic per seed: the glass mask and fog are the first render's
    assert np.array_equal(again.mean["mask_specular"], first.mean["mask_specular"])
    assert np.array_equal(again.mean["fog"], first.mean["fog"])
    meshes = resolve(scene, SETTINGS).description.meshes
    assert {file_sha256(str(p))[:32] for p in plys} == {digest[:32] for digest in meshes}


def _rewrite_entry(empty_cache, result, edit) -> None:
    """Apply ``edit`` (layers → layers) to the entry's EXR and make its manifest match
    the new bytes: damage the hash cannot see (a bad write upstream, a copied entry)."""
    layers, _ = read_exr(result.exr_path)
    write_exr(result.exr_path, edit(layers))
    path = _manifest_path(empty_cache, result.key)
    manifest = json.loads(path.read_text())
    manifest["exr_sha256"] = file_sha256(result.exr_path)
    path.write_text(json.dumps(_resealed(manifest)))


def _nan_pixel(layers):
    layers["caustic"][3, 4, 1] = np.nan
    return layers


def _inf_variance(layers):
    layers["combined_var"][0, 0, 0] = np.inf
    return layers


def _negative_variance(layers):
    layers["fog_var"][1, 1, 2] = -1.0
    return layers


def _wrong_size(layers):
    return {name: image[:8, :8] for name, image in layers.items()}


def _layer_missing(layers):
    del layers["direct_var"]
    return layers


@pytest.mark.parametrize("edit", [_nan_pixel, _inf_variance, _negative_variance, _wrong_size, _layer_missing])
def test_an_entry_with_bad_layers_is_rerendered_never_served(empty_cache, edit):
    """An entry whose EXR matches its manifest's hash but holds a non-finite value, a
    negative variance, another image size or too few layers is re-rendered (before: it
    was served as ground truth)."""
    scene = load_builtin("refocus")
    first = render_reference(scene, SETTINGS, progress=False)
    _rewrite_entry(empty_cache, first, edit)
    assert cache.existing_reference(scene, SETTINGS) is None
    again = render_reference(scene, SETTINGS, progress=False)
    assert not again.cached
    assert all(np.isfinite(v).all() for v in again.mean.values()) and again.mean["caustic"].shape == (12, 16, 3)
    assert render_reference(scene, SETTINGS, progress=False).cached


@pytest.mark.parametrize("damage", ["garbage", "truncated", "another entry's state", "another size, hash matching"])
def test_a_damaged_batch_state_restarts_the_render(empty_cache, damage):
    """A continued entry whose batch state does not match its manifest, or is not a
    state of its image (another size: before, adding a batch to it raised), is
    rendered afresh (the state is never added to)."""
    scene = load_builtin("refocus")
    first = render_reference(scene, SETTINGS, progress=False)
    states = sorted((empty_cache / "reference").glob("*.npz"))
    assert len(states) == 1
    if damage == "garbage":
        states[0].write_bytes(b"PK\x03\x04 garbage")
    elif damage == "truncated":
        states[0].write_bytes(states[0].read_bytes()[:100])
    else:
        size = {"width": 8, "height": 6} if damage.startswith("another size") else {"width": 16, "height": 12}
        other = render_reference(scene, ReferenceSettings(photons=100000, spp=8, batches=2, seed=7, **size),
                                 progress=False)
        other_state = [p for p in (empty_cache / "reference").glob("*.npz") if other.key in p.name]
        states[0].write_bytes(other_state[0].read_bytes())
        if damage.startswith("another size"):  # a manifest that agrees: damage its hash cannot see
            path = _manifest_path(empty_cache, first.key)
            path.write_text(json.dumps(_resealed({**json.loads(path.read_text()),
                                                  "state_sha256": file_sha256(str(states[0]))})))
    more = render_reference(scene, ReferenceSettings(photons=150000, spp=12, batches=3, width=16, height=12),
                            progress=False)
    assert more.key == first.key and more.manifest["batches"] == 3
    assert more.manifest["wall_seconds"] == pytest.approx(more.manifest["seconds_this_call"])  # started afresh


@pytest.mark.parametrize("writer", ["atomic_write_bytes", "atomic_write_text"])
def test_an_interrupted_continuation_keeps_the_entry_it_continued(empty_cache, monkeypatch, writer):
    """Ctrl-C while a continued entry is written (as its PNG is written, after the EXR;
    as its manifest is written, the latest moment) leaves the old entry valid, with its
    render time and batch state, and no stray files (before: its EXR was already
    overwritten, so the entry was damaged and its render time lost)."""
    scene = load_builtin("refocus")
    first = render_reference(scene, SETTINGS, progress=False)
    folder = empty_cache / "reference"
    before = sorted(os.listdir(folder))

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    more = ReferenceSettings(photons=200000, spp=16, batches=4, width=16, height=12)  # same batches, more of them
    with monkeypatch.context() as patch:
        patch.setattr(cache, writer, interrupted)
        with pytest.raises(KeyboardInterrupt):
            render_reference(scene, more, progress=False)
    assert sorted(os.listdir(folder)) == before
    kept = render_reference(scene, SETTINGS, progress=False)
    assert kept.cached and kept.manifest["wall_seconds"] == first.manifest["wall_seconds"]
    assert all(np.array_equal(kept.mean[k], first.mean[k]) for k in first.mean)
    continued = render_reference(scene, more, progress=False)
    assert continued.manifest["batches"] == 4
    assert continued.manifest["wall_seconds"] > first.manifest["wall_seconds"]  # the old batches' time kept
    assert continued.manifest["wall_seconds"] > continued.manifest["seconds_this_call"]
    # the switch: one manifest, and only the files it names (the continued entry's) remain
    names = sorted(os.listdir(folder))
    assert len([n for n in names if n.endswith(".json")]) == 1
    assert len([n for n in names if n.endswith(".exr")]) == 1 and os.path.basename(continued.exr_path) in names
    assert render_reference(scene, more, progress=False).cached


def test_files_a_killed_writer_left_go_with_the_next_write(empty_cache):
    """SIGKILL between an entry's data files and its manifest runs no ``finally``: its
    new files stayed for ever. The next write removes those of a process that is gone
    and that no manifest names; a running writer's files and the entry's own stay."""
    import subprocess
    import sys

    from volcaustics.infra.storage import owner

    scene = load_builtin("refocus")
    first = render_reference(scene, SETTINGS, progress=False)
    folder = empty_cache / "reference"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    host = owner().rsplit("-", 1)[0]
    orphan = folder / f"{first.key}.{host}-{dead.pid}-0123456789ab.exr"
    running = folder / f"{first.key}.{host}-{os.getpid()}-0123456789ab.exr"
    for path in (orphan, running):
        path.write_bytes(b"half")
    render_reference(scene, ReferenceSettings(photons=150000, spp=12, batches=3, width=16, height=12),
                     progress=False)  # continues the entry: a write
    names = os.listdir(folder)
    assert orphan.name not in names and running.name in names
    assert len([n for n in names if n.endswith(".exr")]) == 2  # the running writer's and the entry's


def _resealed(doc: dict) -> dict:
    """``doc`` with its seal recomputed (as the cache writes it), where it has one (NaN: none)."""
    try:
        return {**doc, cache.SEAL: document_sha256(doc, cache.SEAL)}
    except ValueError:
        return doc


@pytest.mark.parametrize("edit", [{"noise_floor": {"caustic": 1e-9, "fog": 1e-9, "direct": 1e-9, "combined": 1e-9}},
                                  {"batches": 1000, "photons": 10**9}])
def test_a_manifest_with_numbers_edited_is_a_damaged_entry(empty_cache, edit):
    """The manifest's numbers were not verified: floors edited to 1e-9 were served as
    meeting a 0.01% noise target, and 1000 batches were reported (hostile pass). The
    manifest carries the SHA-256 of itself: an edited one is re-rendered."""
    scene = load_builtin("refocus")
    first = render_reference(scene, SETTINGS, progress=False)
    path = _manifest_path(empty_cache, first.key)
    path.write_text(json.dumps({**json.loads(path.read_text()), **edit}))
    assert cache.cached_reference(first.key, scene) is None
    again = render_reference(scene, SETTINGS, progress=False)
    assert not again.cached and again.manifest["batches"] == SETTINGS.batches


@pytest.mark.parametrize("edit", [{"files": ["a list"]}, {"files": {"exr": "../elsewhere.exr"}}, {"files": None},
                                  {"settings": 5}, {"settings": {"width": 8, "height": 6}}, {"exr_sha256": None},
                                  {"batches": "2"}, {"noise_floor": [0.1]}, {"noise_floor": {"caustic": float("nan")}},
                                  {"wall_seconds": None}])
def test_a_manifest_of_the_wrong_shape_is_a_damaged_entry(empty_cache, edit):
    """A manifest whose fields are not what the cache writes (files not a table of this
    entry's own file names, settings not a table of its size, counts, floors or seconds
    not numbers) is a damaged entry: re-rendered, never a crash (before: a list of
    floors raised), and never a reason to read or remove a file outside the entry."""
    scene = load_builtin("refocus")
    first = render_reference(scene, SETTINGS, progress=False)
    path = _manifest_path(empty_cache, first.key)
    path.write_text(json.dumps(_resealed({**json.loads(path.read_text()), **edit})))  # the type checks, not the seal
    outside = empty_cache / "elsewhere.exr"
    outside.write_bytes(b"not the cache's")
    assert cache.cached_reference(first.key, scene) is None
    assert not render_reference(scene, SETTINGS, progress=False).cached
    assert outside.read_bytes() == b"not the cache's"
