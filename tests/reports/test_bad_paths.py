"""Output paths, cache folders and special files: every command fails fast with exit 2
and a message naming the path, before it renders."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from volcaustics.reports.cli import main

ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False


def _fails_fast(capsys, argv, fragment, *, within=20.0):
    t0 = time.perf_counter()
    assert main(argv) == 2
    # nothing rendered: a render of the smallest built-in takes longer than this on any machine we know
    assert time.perf_counter() - t0 < within
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err
    return err


@pytest.mark.parametrize("output, fragment", [
    ("", "expected a file name ending in .exr"),
    ("sub/", "expected a file name ending in .exr"),
    ("out.png", "ending in .exr"),
    (".exr", "ending in .exr"),
    ("a_file/out.exr", "is not a folder"),
    ("a_folder.exr", "is a folder"),
    ("clash.exr", "is a folder"),           # its sibling clash.json is a folder
])
@pytest.mark.parametrize("command", ["approx", "reference"])
def test_bad_outputs_of_approx_and_reference(tmp_path, capsys, monkeypatch, command, output, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("x")
    (tmp_path / "a_folder.exr").mkdir()
    (tmp_path / "clash.json").mkdir()
    _fails_fast(capsys, [command, "sphere1", "-o", output], fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "a_folder.exr", "clash.json"]


def test_records_max_below_minus_one_is_refused(tmp_path, capsys):
    _fails_fast(capsys, ["approx", "sphere1", "-o", str(tmp_path / "o.exr"), "--records-max", "-5"],
                "--records-max")


@pytest.mark.parametrize("target, fragment", [
    ("a_file/scene.xml", "is not a folder"),
    ("scene.txt", "ending in .xml"),
    ("meshclash.xml", "is a file"),          # meshclash_meshes is a file
])
def test_bad_outputs_of_export(tmp_path, capsys, monkeypatch, target, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("x")
    (tmp_path / "meshclash_meshes").write_text("x")
    _fails_fast(capsys, ["export", "sphere1", "--mitsuba-xml", target], fragment)


@pytest.mark.parametrize("dangling", [False, True])
def test_export_refuses_a_mesh_folder_that_is_a_symlink(tmp_path, capsys, dangling):
    """OUT_meshes/ as a symbolic link was written through: the PLY files went into the
    folder it names (or a dangling one ended in a traceback). Refused, naming it; the
    folder it names is left as it was."""
    elsewhere = tmp_path / "elsewhere"
    if not dangling:
        elsewhere.mkdir()
    (tmp_path / "s_meshes").symlink_to(elsewhere, target_is_directory=True)
    err = _fails_fast(capsys, ["export", "sphere1", "--mitsuba-xml", str(tmp_path / "s.xml")], "symbolic link")
    assert str(tmp_path / "s_meshes") in err
    assert not (tmp_path / "s.xml").exists()
    assert (sorted(p.name for p in elsewhere.iterdir()) == []) if not dangling else not elsewhere.exists()
    from volcaustics.reference.render.export import ExportError, export_xml
    from volcaustics.scenes import load_builtin

    with pytest.raises(ExportError, match="symbolic link"):  # the library refuses it too
        export_xml(load_builtin("sphere1"), str(tmp_path / "s.xml"))
    assert (sorted(p.name for p in elsewhere.iterdir()) == []) if not dangling else not elsewhere.exists()


@pytest.mark.skipif(ROOT, reason="root writes into read-only folders: the case cannot be made as root")
def test_a_read_only_output_folder(tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        _fails_fast(capsys, ["approx", "sphere1", "-o", str(folder / "o.exr")], "not a writable folder")
    finally:
        folder.chmod(0o755)


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_cache_that_is_a_file_is_named_as_such(tmp_path):
    """Not "an error in the scene's mesh": the cache folder, and the variable to fix (in a
    fresh process: this one may hold the generated meshes in memory already). Listing
    the scenes needs nothing from the cache, so it runs, saying once that the
    generated meshes are not cached."""
    cache = tmp_path / "cache"
    cache.write_text("not a folder")
    done = subprocess.run([sys.executable, "-m", "volcaustics", "scenes"], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "VOLCAUSTICS_CACHE": str(cache)})
    assert done.returncode == 0, done.stderr[-2000:]
    err = done.stderr
    assert err.count("cache folder") == 1 and "VOLCAUSTICS_CACHE" in err and "generated meshes" in err
    assert "Traceback" not in err and "could not be built" not in err and "specular" not in err


def test_a_mesh_path_that_is_a_device_or_fifo(tmp_path, write_scene):
    """/dev/zero was hashed forever and a FIFO blocked: both are refused at once (run in
    a subprocess with a timeout, so a regression fails instead of hanging the suite)."""
    fifo = tmp_path / "mesh.fifo"
    os.mkfifo(fifo)
    for mesh in ("/dev/zero", str(fifo)):
        text = open(write_scene()).read().replace('mesh = { generator = "sphere", radius = 0.5, subdivisions = 3 }',
                                                  f'mesh = "{mesh}"')
        scene = tmp_path / "special.toml"
        scene.write_text(text)
        done = subprocess.run([sys.executable, "-m", "volcaustics", "scenes", "--check", str(scene)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2, done.stderr
        assert "not a regular file" in done.stderr and "Traceback" not in done.stderr


def test_a_scene_file_that_is_a_fifo_or_nested_too_deeply(tmp_path):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    for path, fragment in ((fifo, "not a regular file"), (deep, "invalid TOML")):
        done = subprocess.run([sys.executable, "-m", "volcaustics", "scenes", "--check", str(path)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2, done.stderr
        assert fragment in done.stderr and "Traceback" not in done.stderr


def test_budgets_that_are_a_fifo(tmp_path, capsys):
    fifo = tmp_path / "budgets.toml"
    os.mkfifo(fifo)
    _fails_fast(capsys, ["gate", "--budgets", str(fifo), "--out", str(tmp_path / "g")], "not a regular file")


@pytest.mark.parametrize("command", ["gate", "report"])
def test_a_baseline_that_is_a_file_is_named_as_such(tmp_path, capsys, empty_cache, command):
    """It said "Not a directory"; nothing renders before the check."""
    baseline = tmp_path / "baseline.json"
    baseline.write_text("{}")
    _fails_fast(capsys, [command, "--baseline", str(baseline), "--out", str(tmp_path / "out")],
                "is a file: it must be a folder")
    assert not (empty_cache / "reference").exists()


@pytest.mark.parametrize("variable, value, fragment", [
    ("VOLCAUSTICS_MI_VARIANT", "scalar_rgb", "VOLCAUSTICS_MI_VARIANT = 'scalar_rgb'"),
    ("VOLCAUSTICS_MI_VARIANT", "no_such_variant", "expected one of"),
    ("DRJIT_LIBLLVM_PATH", "/nonexistent/libLLVM-19.so", "DRJIT_LIBLLVM_PATH"),
    ("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1", "libLLVM 16 or newer"),
])
def test_unsuitable_environment_variables(tmp_path, variable, value, fragment):
    """A variant the reference cannot render with, a libLLVM that is missing or too old:
    exit 2 naming the variable and the fix (in a subprocess: the variables are read
    when Mitsuba is first imported)."""
    env = {**os.environ, "VOLCAUSTICS_CACHE": str(tmp_path / "cache"), variable: value}
    if variable == "DRJIT_LIBLLVM_PATH":
        env["VOLCAUSTICS_MI_VARIANT"] = "llvm_ad_rgb"
    done = subprocess.run([sys.executable, "-m", "volcaustics", "reference", "sphere1", "-o", str(tmp_path / "r.exr"),
                           "--width", "16", "--height", "16", "--photons", "1000", "--spp", "2", "--batches", "2"],
                          capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 2, done.stderr[-2000:]
    assert fragment in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "r.exr").exists()


@pytest.mark.parametrize("name", ["../x", "/tmp/abs", "a/b", ".hidden", "", "x" * 65])
def test_a_scene_name_that_is_no_file_name(tmp_path, write_scene, capsys, name):
    """The name becomes the preview's file name: one that would write outside the folder
    (or hide the file) is refused, and nothing is written anywhere."""
    text = open(write_scene()).read().replace('name = "base"', f'name = "{name}"')
    scene = tmp_path / "named.toml"
    scene.write_text(text)
    previews = tmp_path / "p" / "q"
    assert main(["scenes", "--check", str(scene), "--preview", str(previews)]) == 2
    assert "name" in capsys.readouterr().err
    assert not (tmp_path / "p").exists() and not (tmp_path / "x").exists()


@pytest.mark.parametrize("old, new, fragment", [
    ("intensity = [5.0, 5.0, 5.0]", "intensity = [1e308, 5.0, 5.0]", "light.intensity[0]"),
    ("translate = [0.0, 1.0, 0.0]", "translate = [1e300, 1.0, 0.0]", "translate[0]"),
    ("translate = [0.0, 1.0, 0.0] }", "translate = [0.0, 1.0, 0.0], scale = 1e300 }", "scale"),
    ("sigma_s = 0.2", "sigma_s = 1e200", "medium.sigma_s"),
    ("position = [0.0, 1.0, 4.0]", "position = [0.0, 1.0, 4e7]", "camera.position[2]"),
])
def test_values_the_renderers_cannot_represent(tmp_path, write_scene, capsys, old, new, fragment):
    """Values that passed validation and then made inf/NaN images or crashed Mitsuba:
    refused when the scene is read (float32 limits, scenes/loader.py)."""
    text = open(write_scene()).read()
    assert old in text
    scene = tmp_path / "big.toml"
    scene.write_text(text.replace(old, new, 1))
    assert main(["scenes", "--check", str(scene)]) == 2
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err


def test_a_photon_map_beyond_memory_fails_before_rendering(tmp_path, capsys):
    """photon_res 8192 (in range) asked for 7.5 GB of records and failed after 33 s with
    "cannot map the buffer": refused before any GL work, saying what fits."""
    from volcaustics.approx.limits import frame_bytes, memory_budget

    assert frame_bytes(8192, 4) > memory_budget() or pytest.skip("this machine holds a photon_res 8192 frame")
    err = _fails_fast(capsys, ["approx", "sphere1", "--preset", "quick", "--photon-res", "8192",
                               "-o", str(tmp_path / "o.exr")], "photon_res = 8192", within=30.0)
    assert "fits" in err
    assert not list(tmp_path.iterdir())


def test_frame_bytes_counts_every_buffer():
    from volcaustics.approx.limits import frame_bytes
    from volcaustics.scenes.formats import PHOTON_DTYPE, RAW_RECORD_DTYPE, RECORD_DTYPE, SPLAT_DTYPE

    slots = PHOTON_DTYPE.itemsize + RAW_RECORD_DTYPE.itemsize + SPLAT_DTYPE.itemsize
    assert frame_bytes(10, 4) == 100 * slots
    assert frame_bytes(10, 4, keep_records=True) == 100 * (slots + 4 * (RAW_RECORD_DTYPE.itemsize +
                                                                        RECORD_DTYPE.itemsize))


def test_a_reference_seed_out_of_range(tmp_path, capsys):
    _fails_fast(capsys, ["reference", "sphere1", "-o", str(tmp_path / "r.exr"), "--seed", str(2**32)], "seed")


def test_an_interrupted_approx_keeps_the_last_complete_set(tmp_path, monkeypatch):
    """Ctrl-C while the outputs are written (here: inside the PNG writer of the second
    run) leaves the first run's EXR, PNG, records and JSON, byte for byte, and no
    temporary files."""
    import volcaustics.reports.presenting.exports.approx_files as job

    out = tmp_path / "o.exr"
    small = ["--preset", "quick", "--photon-res", "32", "--light-res", "32", "--width", "24", "--height", "24"]
    assert main(["approx", "refocus", *small, "-o", str(out)]) == 0
    first = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert set(first) == {"o.exr", "o.png", "o.records.npz", "o.json"}

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(job, "write_png", interrupted)
    assert main(["approx", "refocus", *small, "--seed", "7", "-o", str(out)]) == 130
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == first


@pytest.mark.parametrize("wrapped", ["message", "chained"])
def test_ctrl_c_inside_mitsuba_exits_130(tmp_path, monkeypatch, capsys, wrapped):
    """Ctrl-C during Mitsuba's render reaches Python as a RuntimeError from C++ (naming
    KeyboardInterrupt, or chained to it): exit 130 and "interrupted", not a traceback
    with exit 1. The interrupt is injected where the render runs."""
    import volcaustics.reports.presenting.exports.reference_files as job

    def render(*args, **kwargs):
        if wrapped == "message":
            raise RuntimeError("drjit.while_loop(): the loop body raised an exception: KeyboardInterrupt")
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise RuntimeError("render failed") from exc

    monkeypatch.setattr(job, "render_reference", render)
    assert main(["reference", "sphere1", "-o", str(tmp_path / "r.exr")]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_other_runtime_errors_are_not_taken_for_interrupts():
    from volcaustics.reports.cli import interrupted

    assert not interrupted(RuntimeError("out of memory"))
    assert interrupted(RuntimeError("x: KeyboardInterrupt"))


@pytest.mark.parametrize("command, other", [
    (["animate", "refocus"], "compare"),     # it replaced the comparison's summary.json: a mixed folder
    (["measure", "sphere1"], "animation"),
    (["compare", "refocus", "image.exr"], "experiment"),
    (["frames", "sphere1"], "animation"),    # both write frames.parquet: the animation's table was replaced
    (["frames", "sphere1"], "experiment"),
    (["sweep", "--scenes", "sphere1", "--vary", "steps=2,4"], "animation"),
    (["gate", "--scenes", "sphere1", "--out"], "animation"),
])
def test_an_output_folder_of_another_command_is_refused(tmp_path, capsys, empty_cache, command, other):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text(f'{{"kind": "{other}"}}')
    option = [] if command[-1] == "--out" else ["-o"]
    _fails_fast(capsys, [*command, *option, str(out), "--quiet"], f"holds another command's outputs (its summary.json "
                                                                   f"is of kind {other!r}")
    assert (out / "summary.json").read_text() == f'{{"kind": "{other}"}}'


@pytest.mark.parametrize("command, marker, other", [
    (["animate", "refocus", "-o"], "frames.json", "frames"),  # it would replace the frame check's table
    (["measure", "sphere1", "-o"], "sweep.json", "sweep"),
    (["frames", "sphere1", "-o"], "gate.json", "gate"),
])
def test_a_folder_another_command_marked_is_refused(tmp_path, capsys, empty_cache, command, marker, other):
    """frames, sweep and gate write no summary.json: their manifests mark their folders."""
    out = tmp_path / "out"
    out.mkdir()
    (out / marker).write_text("{}")
    _fails_fast(capsys, [*command, str(out), "--quiet"], f"holds another command's outputs (its {marker} is of "
                                                          f"kind {other!r}")
    assert (out / marker).read_text() == "{}"


def test_frames_checks_every_scene_before_any_work(tmp_path, capsys, empty_cache):
    """A bad second scene name once exited 2 after 148 s of finished work; two files of one
    scene name ended in a pandas error after 154 s. Both are refused before anything renders."""
    out = tmp_path / "out"
    _fails_fast(capsys, ["frames", "sphere1", "no_such_scene", "-o", str(out), "--quiet"], "no_such_scene")
    knot = (Path(__file__).resolve().parents[2] / "scenes" / "heldout" / "knot.toml").read_text()
    for name in ("a.toml", "b.toml"):
        (tmp_path / name).write_text(knot)
    err = _fails_fast(capsys, ["frames", str(tmp_path / "a.toml"), str(tmp_path / "b.toml"), "-o", str(out),
                               "--quiet"], "are both scene")
    assert "a.toml" in err and "b.toml" in err and not out.exists()


@pytest.mark.parametrize("command", [["approx", "refocus", "-o", "{out}/a.exr"],
                                     ["measure", "refocus", "-o", "{out}/m", "--quiet"]])
def test_a_denoiser_that_cannot_load_is_refused_before_any_work(tmp_path, capsys, empty_cache, monkeypatch, command):
    """`denoise = oidn` without a loadable OIDN binding (here: the module made unimportable)
    once failed mid-render with a RuntimeError traceback; now exit 2 at once, naming it."""
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # `import pyoidn` raises ImportError
    argv = [a.format(out=tmp_path) for a in command]
    _fails_fast(capsys, [*argv, "--denoise", "oidn"], "denoise = oidn: pyoidn (Intel Open Image Denoise) cannot load")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("argv, fragment", [
    (["sweep", "--scenes", "refocus", "--criterion", "bias"], "--criterion"),  # was silently ignored without --best
    (["sweep", "--scenes", "refocus", "--dask", "local:1", "--workers", "2"], "--workers"),  # ignored beside --dask
    (["measure", "refocus", "--preset", "best", "--exact-subphotons", "0"], "--exact-subphotons = 0"),  # after a match
    (["measure", "refocus", "--preset", "best", "--width", "8"], "width"),
    (["sweep", "--scenes", "refocus", "--vary", "temporal=none,ema"], "temporal acts only"),  # two identical points
    (["animate", "refocus", "--temporal", "ema", "--fixed-seed"], "--seed-per-frame"),  # measured every seed mode
])
def test_a_flag_ignored_or_refused_late_is_refused_at_once(tmp_path, capsys, empty_cache, argv, fragment):
    _fails_fast(capsys, [*argv, "-o", str(tmp_path / "out"), "--quiet"], fragment, within=5.0)
    assert not (tmp_path / "out").exists()
