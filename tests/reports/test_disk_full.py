"""A full disk: the error names the output it was
writing, never a hidden temporary or no file at all, and leaves nothing behind. A real
full file system: a tmpfs of a few KiB (mounting needs root; skipped, saying so, without)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.shared import SWEEP_SPEC
from volcaustics.reports.cli import main


@pytest.fixture
def full_disk(tmp_path, request):
    """A tmpfs of 12 KiB (or ``request.param``: parametrize indirectly)."""
    folder = tmp_path / "full"
    folder.mkdir()
    size = getattr(request, "param", "12k")
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here (needs root): {mounted.stderr.strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=False)


def test_approx_onto_a_full_disk_names_its_output(full_disk, tmp_path, capsys, empty_cache):
    """OpenEXR said "Failed to write pixel data to image file ..tmp.exr" as a RuntimeError:
    a traceback naming a hidden temporary."""
    shot = full_disk / "shot.exr"
    assert main(["approx", "refocus", "--preset", "quick", "--width", "64", "--height", "64", "-o", str(shot)]) == 2
    err = capsys.readouterr().err
    assert f"{shot}: No space left on device" in err and "Traceback" not in err, err
    assert list(Path(full_disk).iterdir()) == []


def test_a_set_whose_writer_fails_without_a_file_name_names_its_output(full_disk):
    """A writer that reports a full disk naming no file (pyarrow, numpy) is given the
    output it was writing."""
    import numpy as np

    from volcaustics.infra.storage import atomic_set

    paths = [str(full_disk / "big.npy"), str(full_disk / "manifest.json")]
    with pytest.raises(OSError) as info:
        with atomic_set(paths) as temps:
            with open(temps[0], "wb") as fh:
                fh.write(np.zeros(1 << 16).tobytes())  # 512 KiB onto 12 KiB
    assert info.value.filename == paths[0] and info.value.errno == 28
    assert list(Path(full_disk).iterdir()) == []


def test_reference_onto_a_full_disk_names_its_output_not_the_cache(full_disk, tmp_path, capsys, empty_cache):
    """The copy out of the cache failed naming its source, the cache file, although the
    cache's disk had room."""
    shot = full_disk / "ref.exr"
    assert main(["reference", "refocus", "--width", "32", "--height", "32", "--photons", "20000", "--spp", "2",
                 "--batches", "2", "-o", str(shot)]) == 2
    err = capsys.readouterr().err
    assert f"{shot}: No space left on device" in err and "Traceback" not in err, err
    assert list(Path(full_disk).iterdir()) == []


def test_an_output_name_near_the_limit_is_written(tmp_path):
    """A 254-character file name is legal; its temporary added ~25 characters and failed
    with "File name too long", naming the temporary."""
    from volcaustics.infra.storage import atomic_set, atomic_write_text

    long = "a" * 250
    paths = [str(tmp_path / f"{long}.exr"), str(tmp_path / f"{long}.json")]
    with atomic_set(paths) as temps:
        for tmp in temps:
            Path(tmp).write_text("new")
    atomic_write_text(str(tmp_path / f"{long}.txt"), "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([f"{long}.exr", f"{long}.json", f"{long}.txt"])


# 12 KiB: neither a point nor the tables fit; 40 KiB: a point's first table (47 KB at this size) does not, the
# tables of no point (a page each) do: the sweep then wrote sweep.json and empty tables, exit 1
@pytest.mark.parametrize("full_disk", ["12k", "40k"], indirect=True)
def test_a_sweep_onto_a_full_disk_exits_2_naming_the_point_and_writes_no_tables(full_disk, tmp_path, capsys, cache):
    """A point whose worker found the disk full was "point failed" (exit 1) naming no
    file, and the sweep then wrote sweep.json and empty tables. A full disk is the
    machine's fault, not the point's: the sweep stops, exit 2, naming the point's folder
    (not its hidden temporary), with no table, manifest or half point left."""
    spec = tmp_path / "sweep.toml"
    spec.write_text(SWEEP_SPEC)
    out = full_disk / "store"
    assert main(["sweep", str(spec), "-o", str(out), "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{out / 'points'}/" in err and ": No space left on device" in err, err
    assert ".tmp-" not in err and "Traceback" not in err and "failed" not in err, err
    assert not (out / "sweep.json").exists() and not list(out.glob("*.parquet"))
    assert list((out / "points").iterdir()) == []  # no half point, no temporary


def test_a_point_sent_back_onto_a_full_disk_names_the_point_not_its_temporary(full_disk):
    """A Dask worker's point is written into this store by the run (``Store.adopt_point``):
    a full disk there (the write names no file) names the point's folder, never the
    hidden temporary folder, and leaves nothing behind."""
    from volcaustics.reports.measuring.results.store import Store

    store, key = Store(str(full_disk / "store")), "0" * 32
    with pytest.raises(OSError) as info:
        store.adopt_point(key, {"segments.parquet": bytes(1 << 16)})  # 64 KiB onto 12 KiB
    assert info.value.errno == 28 and info.value.filename == str(full_disk / "store" / "points" / key)
    assert list((full_disk / "store" / "points").iterdir()) == []
