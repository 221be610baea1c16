"""Faults at chosen points in measure, sweep, gate, report and scenes: limits
checked before any reference renders (class D), writes interrupted midway that leave
the last complete set and no earlier verdict standing for a run that stopped (B),
Ctrl-C inside the reference render (F), damaged and special manifests (E, H), output
options checked up front (A). Each test injects the fault where the command meets it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from tests.shared import SWEEP_SPEC as SPEC  # tiny points: 32², photon_res 64, light_res 64; 4 batches
from volcaustics.reports.cli import main

REPO = Path(__file__).resolve().parents[2]
# a frame of photon_res 8192 with 32 steps reads back ~0.5 TB of records
HUGE = ["--set", "photon_res=8192", "--set", "steps=32"]


@pytest.fixture
def cache(empty_cache):
    """Most tests here check what a command leaves behind: an empty cache of their own."""
    return empty_cache


def _nothing_rendered(cache: Path) -> bool:
    return not cache.exists() or not any(cache.rglob("*.exr"))


def _exit_2(capsys, argv, fragment, *, within=20.0) -> str:
    t0 = time.perf_counter()
    assert main(argv) == 2
    # nothing rendered: the smallest reference takes longer than this on any machine we know
    assert time.perf_counter() - t0 < within
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err, err
    return err


# --- D: limits before the references ------------------------------------------------

@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
@pytest.mark.parametrize("command", ["measure", "sweep", "gate", "report"])
def test_a_frame_beyond_memory_fails_before_any_reference_renders(cache, tmp_path, capsys, command):
    """photon_res passes its range but the frame cannot run: measure, sweep, gate and
    report rendered the references first (minutes at the report's budget) and failed in
    the approximation after them; now they exit 2 at once, saying what fits."""
    from volcaustics.approx.limits import frame_bytes, memory_budget

    if frame_bytes(8192, 32, keep_records=True) <= memory_budget():
        pytest.skip("this machine holds a photon_res 8192, 32-step frame")
    argv = {"measure": ["measure", "sphere1", "-o", str(tmp_path / "m"), "--photon-res", "8192", "--steps", "32"],
            "sweep": ["sweep", "-o", str(tmp_path / "s"), "--scenes", "sphere1", "--vary", "layers=1,2", *HUGE],
            "gate": ["gate", "--out", str(tmp_path / "g"), "--scenes", "sphere1", "--render-references", *HUGE],
            "report": ["report", "--out", str(tmp_path / "r"), "--scenes", "sphere1", *HUGE]}[command]
    err = _exit_2(capsys, [*argv, "--quiet"], "photon_res = 8192")
    assert "fits" in err
    assert _nothing_rendered(cache)


def test_check_fits_names_the_driver_limit():
    """The work-group limit part, with a driver limit given (Mesa's 65,535): photon_res
    2048 needs 65,536 groups of 64."""
    import dataclasses

    from volcaustics.approx.limits import check_fits
    from volcaustics.approx.params import QUICK, ParamError

    check_fits(dataclasses.replace(QUICK, photon_res=2047), max_groups=65535)
    with pytest.raises(ParamError, match="photon_res = 2048: .* at most 2047"):
        check_fits(dataclasses.replace(QUICK, photon_res=2048), max_groups=65535)
    with pytest.raises(ParamError, match="light_res = 4096: .* at most 4095"):
        check_fits(dataclasses.replace(QUICK, light_res=4096), max_groups=65535)


def test_a_size_suggested_for_memory_is_one_the_driver_runs(monkeypatch):
    """A frame beyond memory once suggested photon_res ≤ 2859 where the driver dispatches at
    most 2047 (which then failed in turn): the suggestion is the smaller of the two. A
    budget of 1 TiB (the negative control) leaves the memory check silent."""
    import dataclasses
    import re

    from volcaustics.approx import limits
    from volcaustics.approx.params import QUICK, ParamError

    params = dataclasses.replace(QUICK, photon_res=8192, steps=32)
    monkeypatch.setattr(limits, "memory_budget", lambda: 64 * 2**30)  # a 128 GiB machine's half
    with pytest.raises(ParamError, match="half of this machine's memory") as refused:
        limits.check_fits(params, keep_records=True, max_groups=65535)
    assert int(re.search(r"photon_res ≤ (\d+) fits", str(refused.value)).group(1)) <= 2047
    monkeypatch.setattr(limits, "memory_budget", lambda: 2**40)
    with pytest.raises(ParamError, match="at most 2047"):
        limits.check_fits(params, keep_records=True, max_groups=65535)


def test_check_fits_counts_the_light_maps(monkeypatch):
    """light_res was checked against the work-group limit only: 16 maps at 4095² need
    ~20 GiB (LIGHT_MAP_BYTES_PER_TEXEL), an allocation failure deep in GL. With a 4 GiB
    budget, light_res 4095 at 8 layers is refused up front, naming what fits, and 1024
    (1.25 GiB of maps) passes."""
    import dataclasses

    import volcaustics.approx.limits as limits
    from volcaustics.approx.params import QUICK, ParamError

    monkeypatch.setattr(limits, "memory_budget", lambda: 4 * 2**30)
    limits.check_fits(dataclasses.replace(QUICK, light_res=1024, layers=8), max_groups=65535)
    with pytest.raises(ParamError, match=r"light_res = 4095: 16 light maps .* light_res ≤ 18\d\d fits"):
        limits.check_fits(dataclasses.replace(QUICK, light_res=4095, layers=8), max_groups=65535)


# --- F: Ctrl-C inside the reference render ------------------------------------------

# the gate's case renders its budgets' references first (about 6 s): marked slow, the others stay fast
@pytest.mark.parametrize("command", ["measure", "sweep", pytest.param("gate", marks=pytest.mark.slow), "report"])
def test_ctrl_c_inside_the_reference_render_exits_130(cache, tmp_path, monkeypatch, capsys, command):
    """Dr.Jit hands a KeyboardInterrupt raised during its loops back as a RuntimeError
    chained to it; every command that renders a reference exits 130 with "interrupted"."""
    import volcaustics.reports.measuring.runner as runner

    def render(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise RuntimeError("drjit.while_loop(): the loop body raised an exception") from exc

    monkeypatch.setattr(runner, "render_references", render)  # where every command renders its references
    small = ["--set", "width=32", "--set", "height=32", "--set", "photon_res=64", "--set", "light_res=64"]
    argv = {"measure": ["measure", "sphere1", "-o", str(tmp_path / "m"), "--width", "32", "--height", "32"],
            "sweep": ["sweep", "-o", str(tmp_path / "s"), "--scenes", "sphere1", "--vary", "layers=1,2", *small],
            "gate": ["gate", "--out", str(tmp_path / "g"), "--scenes", "sphere1", "--render-references", *small],
            "report": ["report", "--out", str(tmp_path / "r"), "--scenes", "sphere1", *small]}[command]
    assert main([*argv, "--quiet"]) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err and "Traceback" not in err


# --- B: interrupted writes ----------------------------------------------------------

def _files(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_an_interrupted_sweep_keeps_its_last_complete_set_of_tables(cache, tmp_path, monkeypatch, capsys):
    """Ctrl-C while the second sweep writes its tables (after its points are stored):
    sweep.json, the four tables and suffice.csv stay the first sweep's, byte for byte, so
    `report --sweep` never reads one run's manifest beside another's tables (sweep.json
    was written before the points, and each table on its own); the rerun completes the
    set from the store without recomputing."""
    out = tmp_path / "store"
    first_spec, second_spec = tmp_path / "one.toml", tmp_path / "two.toml"
    one_iteration = SPEC.replace("iterations = [4, 8]", "iterations = [4]")
    first_spec.write_text(one_iteration.replace("layers = [1, 2]", "layers = [1]"))
    second_spec.write_text(one_iteration)
    assert main(["sweep", str(first_spec), "-o", str(out), "--workers", "1", "--quiet"]) == 0
    first = _files(out)
    assert {"sweep.json", "points.parquet", "images.parquet", "suffice.csv"} <= set(first)

    real = pd.DataFrame.to_parquet
    calls = []

    def to_parquet(self, path, *args, **kwargs):  # the points are written in worker processes
        calls.append(path)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(self, path, *args, **kwargs)

    monkeypatch.setattr(pd.DataFrame, "to_parquet", to_parquet)
    assert main(["sweep", str(second_spec), "-o", str(out), "--workers", "1", "--quiet"]) == 130
    assert len(calls) == 2
    assert _files(out) == first  # no temporaries either
    monkeypatch.setattr(pd.DataFrame, "to_parquet", real)

    capsys.readouterr()
    assert main(["sweep", str(second_spec), "-o", str(out), "--workers", "1", "--quiet"]) == 0
    assert "2 points: 2 already in the store, 0 computed" in capsys.readouterr().out
    manifest = json.loads((out / "sweep.json").read_text())
    assert manifest["spec"]["vary"] == {"layers": [1, 2], "iterations": [4]}
    assert sorted(pd.read_parquet(out / "points.parquet")["point"]) == manifest["keys"]


def test_an_interrupted_gate_leaves_no_earlier_verdict(cache, tmp_path, monkeypatch):
    """A stopped gate must not leave the last run's gate.json or JUnit file for CI to
    read as this run's verdict: both are removed when the run starts measuring."""
    import volcaustics.reports.measuring.runner as runner

    out, junit = tmp_path / "gate", tmp_path / "junit.xml"
    out.mkdir()
    (out / "gate.json").write_text(json.dumps({"passed": True, "exit_code": 0}))
    junit.write_text('<testsuite name="volcaustics-gate" tests="1" failures="0"/>')

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "measure", interrupted)
    assert main(["gate", "--out", str(out), "--junit", str(junit), "--scenes", "sphere1", "--quiet"]) == 130
    assert not (out / "gate.json").exists() and not junit.exists()


# --- A: output options checked up front -----------------------------------------------

@pytest.mark.parametrize("argv, fragment", [
    (["gate", "--junit", "{a_file}/junit.xml"], "--junit"),
    (["gate", "--junit", "{tmp}/junit.txt"], "ending in .xml"),
    (["gate", "--junit", ""], "ending in .xml"),
    (["gate", "--baseline", "{a_file}", "--update-baseline"], "--baseline"),
    (["scenes", "--preview", "{a_file}"], "--preview"),
    (["scenes", "--preview", "{a_file}/sub"], "--preview"),
])
def test_bad_output_options_fail_before_any_work(cache, tmp_path, capsys, argv, fragment):
    a_file = tmp_path / "a_file"
    a_file.write_text("keep me")
    argv = [a.format(a_file=a_file, tmp=tmp_path) for a in argv]
    if argv[0] == "gate":
        argv += ["--out", str(tmp_path / "g"), "--scenes", "sphere1", "--render-references", "--quiet"]
    _exit_2(capsys, argv, fragment)
    assert a_file.read_text() == "keep me"
    assert _nothing_rendered(cache)


# --- E, H: damaged and special manifests -------------------------------------------

@pytest.mark.parametrize("content", ["null", "[]", "\0\xff garbage", "{"])
def test_a_damaged_baseline_or_sweep_manifest_exits_2(cache, tmp_path, capsys, content):
    baseline, sweep = tmp_path / "baseline", tmp_path / "sweep"
    baseline.mkdir()
    sweep.mkdir()
    (baseline / "baseline.json").write_text(content, encoding="latin-1")
    (sweep / "sweep.json").write_text(content, encoding="latin-1")
    _exit_2(capsys, ["gate", "--out", str(tmp_path / "g"), "--scenes", "sphere1", "--baseline", str(baseline),
                     "--quiet"], "baseline")
    _exit_2(capsys, ["report", "--out", str(tmp_path / "r"), "--scenes", "sphere1", "--sweep", str(sweep),
                     "--quiet"], "sweep.json")
    assert _nothing_rendered(cache)


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
@pytest.mark.parametrize("case", ["gate-baseline", "report-sweep"])
def test_a_manifest_that_is_a_fifo_does_not_hang(tmp_path, case):
    """Opening a FIFO blocks until a writer comes: a fresh process with a time limit, so
    a hang fails the test instead of stopping the suite."""
    folder = tmp_path / "m"
    folder.mkdir()
    name = {"gate-baseline": "baseline.json", "report-sweep": "sweep.json"}[case]
    os.mkfifo(folder / name)
    argv = {"gate-baseline": ["gate", "--out", str(tmp_path / "g"), "--scenes", "sphere1", "--baseline",
                              str(folder)],
            "report-sweep": ["report", "--out", str(tmp_path / "r"), "--scenes", "sphere1", "--sweep", str(folder)]}
    env = {**os.environ, "VOLCAUSTICS_CACHE": str(tmp_path / "cache"), "VOLCAUSTICS_MI_VARIANT": "llvm_ad_rgb"}
    done = subprocess.run([sys.executable, "-m", "volcaustics", *argv[case], "--quiet"], capture_output=True,
                          text=True, env=env, cwd=REPO, timeout=120)
    assert done.returncode == 2, done.stderr[-2000:]
    assert "not a regular file" in done.stderr and "Traceback" not in done.stderr


def _a_complete_point(tmp_path):
    """A store holding one complete point (real Parquet tables, their hashes in its
    summary): (store, key, summary)."""
    from volcaustics.infra.storage import file_sha256
    from volcaustics.reports.measuring.results.store import SUMMARY, TABLE_FILES, Store, sealed

    store = Store(str(tmp_path / "store"))
    key = "0123456789abcdef0123456789abcdef"
    folder = Path(store.point_dir(key))
    folder.mkdir()
    files = {}
    for name in TABLE_FILES:
        pd.DataFrame({"x": [1.0, 2.0]}).to_parquet(folder / name, index=False)
        files[name] = file_sha256(str(folder / name))
    summary = sealed({"key": key, "files": files})
    (folder / SUMMARY).write_text(json.dumps(summary))
    return store, key, summary


@pytest.mark.parametrize("damage", ["summary null", "summary list", "summary garbage", "summary of another key",
                                    "table missing", "table truncated", "unknown file listed"])
def test_a_damaged_store_point_counts_as_damaged(tmp_path, damage):
    """A point whose summary is not its own object, or whose files do not match the
    hashes it lists, is "damaged" (recomputed by the sweep and the report), never read."""
    from volcaustics.reports.measuring.results.store import SUMMARY, TABLE_FILES, sealed

    store, key, summary = _a_complete_point(tmp_path)
    folder, files = Path(store.point_dir(key)), summary["files"]
    assert store.status(key) == "done"

    table = folder / TABLE_FILES[0]
    if damage == "summary null":
        (folder / SUMMARY).write_text("null")
    elif damage == "summary list":
        (folder / SUMMARY).write_text("[]")
    elif damage == "summary garbage":
        (folder / SUMMARY).write_bytes(b"\0\xff{")
    elif damage == "summary of another key":
        (folder / SUMMARY).write_text(json.dumps(sealed({**summary, "key": "f" * 32})))
    elif damage == "table missing":
        table.unlink()
    elif damage == "table truncated":
        table.write_bytes(table.read_bytes()[:-10])
    else:
        (folder / SUMMARY).write_text(json.dumps(sealed({**summary, "files": {**files, "../outside": "0" * 64}})))
    assert store.status(key) == "damaged"
    store.remove_damaged(key)
    assert store.status(key) == "missing" and not list(Path(store.points).iterdir())


# --- re-run of the hostile-user pass: what it still found ---------------------------

def test_a_reference_batch_beyond_mitsubas_sample_limit_is_refused(cache, tmp_path, capsys):
    """One batch is one Mitsuba render; beyond 2^32 samples Mitsuba splits it into passes
    its sampler refuses (a RuntimeError traceback after the first batch): refused up
    front, saying how many photons fit (class D)."""
    from volcaustics.reference.settings import ReferenceSettings, SettingsError

    ReferenceSettings(photons=2**32 * 2, batches=2, spp=4, width=32, height=32)  # exactly 2^32 per batch
    with pytest.raises(SettingsError, match="photons = 17179869184: .* at most 8,589,934,592 photons"):
        ReferenceSettings(photons=2**34, batches=2, spp=4, width=32, height=32)
    with pytest.raises(SettingsError, match="spp = 1048576: .* at most 32,768 spp"):
        ReferenceSettings(photons=65536, batches=2, spp=2**20, width=512, height=512)
    _exit_2(capsys, ["measure", "sphere1", "-o", str(tmp_path / "m"), "--width", "32", "--height", "32",
                     "--photons", str(2**34), "--batches", "2", "--spp", "4", "--target-noise", "none", "--quiet"],
            "more than Mitsuba renders at once")
    assert _nothing_rendered(cache)


@pytest.mark.parametrize("value", ["/nonexistent/libLLVM-19.so", "text file"])
def test_a_bad_libllvm_path_exits_2_in_the_commands_that_render_references(tmp_path, value):
    """The variant probe ran before the DRJIT_LIBLLVM_PATH check and ended in "no Mitsuba
    variant renders here" as a traceback (class I). A fresh process: this one has
    Mitsuba loaded already."""
    if value == "text file":
        value = str(tmp_path / "libLLVM-19.so")
        Path(value).write_text("not a library")
    env = {k: v for k, v in os.environ.items() if k != "VOLCAUSTICS_MI_VARIANT"}
    env.update(DRJIT_LIBLLVM_PATH=value, VOLCAUSTICS_CACHE=str(tmp_path / "cache"))
    done = subprocess.run([sys.executable, "-m", "volcaustics", "measure", "sphere1", "-o", str(tmp_path / "m"),
                           "--width", "16", "--height", "16", "--quiet"], capture_output=True, text=True, env=env,
                          cwd=REPO, timeout=300)
    assert done.returncode == 2, done.stderr[-2000:]
    assert "DRJIT_LIBLLVM_PATH" in done.stderr and "Traceback" not in done.stderr


@pytest.mark.parametrize("where", ["summary.json", "images.parquet"])
def test_a_fifo_inside_a_store_point_is_damage_not_a_hang(tmp_path, where):
    """Store.summary opened summary.json and hashed the tables without looking: a FIFO
    there blocked the sweep and the report forever (class H). A fresh process with a time
    limit, so a hang fails instead of stopping the suite."""
    store, key, _ = _a_complete_point(tmp_path)
    folder = Path(store.point_dir(key))
    (folder / where).unlink()
    os.mkfifo(folder / where)
    code = (f"from volcaustics.reports.measuring.results.store import Store; s = Store({str(store.root)!r}); "
            f"print(s.status({key!r})); s.remove_damaged({key!r}); print(s.status({key!r}))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert done.stdout.split() == ["damaged", "missing"], done.stderr[-2000:]


def test_a_sweep_table_that_is_a_fifo_is_refused_by_the_report(tmp_path):
    folder = tmp_path / "sweep"
    folder.mkdir()
    (folder / "sweep.json").write_text(json.dumps({"spec": {"vary": {"layers": [1]}}}))
    for name in ("segments", "photons", "images"):
        pd.DataFrame({"x": [1.0]}).to_parquet(folder / f"{name}.parquet")
    os.mkfifo(folder / "points.parquet")
    code = f"from volcaustics.reports.presenting.report.sweep_store import load_sweep; load_sweep({str(folder)!r})"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert "points.parquet is not a regular file" in done.stderr


def test_a_baseline_with_more_values_than_seeds_is_damaged(tmp_path):
    """The paired regression test broadcast (2,) against (3,): a traceback after measuring."""
    from volcaustics.reports.studies.gate.budgets import GateError
    from volcaustics.reports.studies.gate.regression import load_baseline

    entry = {"reference_key": "k", "seeds": [0, 1], "caustic_relmse_per_seed": [0.1, 0.2, 0.3]}
    (tmp_path / "baseline.json").write_text(json.dumps({"format": 1, "scenes": {"sphere1": entry}}))
    with pytest.raises(GateError, match="one caustic_relmse_per_seed value per seed"):
        load_baseline(str(tmp_path))
    entry["caustic_relmse_per_seed"] = [0.1, True]
    (tmp_path / "baseline.json").write_text(json.dumps({"format": 1, "scenes": {"sphere1": entry}}))
    with pytest.raises(GateError, match="damaged"):
        load_baseline(str(tmp_path))


@pytest.mark.parametrize("command, folder_at", [
    ("measure", "summary.json"), ("measure", "images.csv"), ("report", "index.html"), ("report", "summary.json"),
    ("gate", "gate.json"), ("gate-baseline", "baseline.json"), ("sweep", "suffice.csv"), ("sweep", "sweep.json"),
    ("sweep", "points.parquet"),
])
def test_a_folder_where_an_output_file_goes_fails_before_any_work(cache, tmp_path, capsys, command, folder_at):
    """These failed after the work, at the set's renames, naming a temporary file, and
    left the set half replaced (class A)."""
    out = tmp_path / "out"
    (out / folder_at).mkdir(parents=True)
    argv = {"measure": ["measure", "sphere1", "-o", str(out)],
            "report": ["report", "--out", str(out), "--scenes", "sphere1"],
            "gate": ["gate", "--out", str(out), "--scenes", "sphere1", "--render-references"],
            "gate-baseline": ["gate", "--out", str(tmp_path / "g"), "--scenes", "sphere1", "--render-references",
                              "--baseline", str(out), "--update-baseline"],
            "sweep": ["sweep", "-o", str(out), "--scenes", "sphere1", "--vary", "layers=1,2"]}[command]
    _exit_2(capsys, [*argv, "--quiet"], f"{out / folder_at} is a folder where an output file goes")
    assert _nothing_rendered(cache)


def test_a_set_with_a_folder_in_place_of_one_file_is_left_untouched(tmp_path):
    from volcaustics.infra.storage import atomic_set

    (tmp_path / "a.txt").write_text("old a")
    (tmp_path / "b.txt").mkdir()
    (tmp_path / "manifest.json").write_text("old manifest")
    with pytest.raises(IsADirectoryError):
        with atomic_set([str(tmp_path / n) for n in ("a.txt", "b.txt", "manifest.json")]) as temps:
            for tmp in temps:
                Path(tmp).write_text("new")
    assert (tmp_path / "a.txt").read_text() == "old a" and (tmp_path / "manifest.json").read_text() == "old manifest"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt", "manifest.json"]


def test_ctrl_c_during_the_commands_imports_exits_130(monkeypatch, capsys):
    """The imports sat outside the handler: Ctrl-C in the first ~0.2 s printed a
    KeyboardInterrupt traceback (class F)."""
    import builtins

    real = builtins.__import__

    def importing(name, *args, **kwargs):
        if name == "volcaustics.infra.errors":  # imported by every run, before the command
            raise KeyboardInterrupt
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", importing)
    assert main(["doctor"]) == 130
    assert "interrupted" in capsys.readouterr().err


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # the dropped interrupt, on purpose
def test_ctrl_c_that_python_drops_in_a_finalizer_still_exits_130(monkeypatch, capsys):
    """A KeyboardInterrupt raised inside a finalizer is printed as "Exception ignored"
    and dropped: the command went on and exited 0 (class F)."""
    import signal

    import volcaustics.reports.cli.doctor as doctor

    class Finaliser:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # the handler runs here, inside the finalizer

    def command(args):
        Finaliser()  # dropped at once
        return 0

    monkeypatch.setattr(doctor, "run", command)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)  # as at a terminal (not under nohup)
    try:
        assert main(["doctor"]) == 130
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # put back
    finally:
        signal.signal(signal.SIGINT, before)
    assert "interrupted" in capsys.readouterr().err


LOOSE = """preset = "quick"
seeds = 2
[reference]
photons = 65536
spp = 8
batches = 4
target_noise = "none"
[scene.sphere1]
caustic = { relmse_max = 100.0, energy_ratio = [0.0, 10.0], hdr_flip_max = 1.0 }
segments = { missed_step2_max = 1.0, dt_p90_step2_max = 10.0 }
"""


def test_an_interrupted_gate_writes_no_baseline_without_its_verdict(cache, tmp_path, monkeypatch):
    """The accepted baseline, the JUnit file and gate.json are one set: Ctrl-C while it is
    written (here: drawing the JUnit XML) keeps the old baseline byte for byte and writes
    no verdict; the baseline used to be written first and the JUnit file last (class B)."""
    import volcaustics.reports.studies.gate.gate_outputs as gate

    budgets = tmp_path / "budgets.toml"
    budgets.write_text(LOOSE)
    baseline = tmp_path / "baseline"
    baseline.mkdir()
    (baseline / "baseline.json").write_text("the accepted baseline")
    argv = ["gate", "--budgets", str(budgets), "--scenes", "sphere1", "--render-references", "--out",
            str(tmp_path / "g"), "--junit", str(tmp_path / "j.xml"), "--baseline", str(baseline),
            "--update-baseline", "--set", "width=32", "--set", "height=32", "--set", "photon_res=64",
            "--set", "light_res=64", "--quiet"]

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    real = gate.junit_xml
    monkeypatch.setattr(gate, "junit_xml", interrupted)
    assert main(argv) == 130
    assert (baseline / "baseline.json").read_text() == "the accepted baseline"
    assert not (tmp_path / "g" / "gate.json").exists() and not (tmp_path / "j.xml").exists()
    assert not [p for p in (*baseline.iterdir(), *tmp_path.iterdir()) if p.name.startswith(".")]
    monkeypatch.setattr(gate, "junit_xml", real)
    assert main(argv) == 0
    assert json.loads((baseline / "baseline.json").read_text())["scenes"]["sphere1"]["seeds"] == [0, 1]
    assert json.loads((tmp_path / "g" / "gate.json").read_text())["passed"]


@pytest.mark.parametrize("argv, fragment", [
    (["gate", "--seed", "-1"], "--seed = -1"),
    (["gate", "--set", "width=32", "--set", "width=64"], "set twice"),
    (["sweep", "-o", "{tmp}/s", "--scenes", "sphere1", "--vary", "iterations=4,4"], "listed twice"),
    (["sweep", "-o", "{tmp}/s", "--scenes", "sphere1", "--vary", "layers=1,2", "--set", "width=32",
      "--set", "width=64"], "set twice"),
])
def test_lenient_options_are_refused(cache, tmp_path, capsys, argv, fragment):
    _exit_2(capsys, [a.format(tmp=tmp_path) for a in argv] + ["--quiet"], fragment)
    assert _nothing_rendered(cache)


@pytest.mark.parametrize("option", ["--baseline", "--sweep", "--budgets"])
def test_an_empty_path_is_not_taken_for_no_option(tmp_path, capsys, option):
    with pytest.raises(SystemExit) as exit_:
        main(["report", "--out", str(tmp_path / "r"), option, ""])
    assert exit_.value.code == 2
    assert "expected a path, not an empty string" in capsys.readouterr().err


def test_a_cuda_variant_where_cuda_does_not_start_exits_2(tmp_path):
    """VOLCAUSTICS_MI_VARIANT=cuda_ad_rgb on a machine without a CUDA driver ended in an
    ImportError traceback from mi.set_variant (hostile pass); skipped where CUDA works."""
    env = {**os.environ, "VOLCAUSTICS_CACHE": str(tmp_path / "cache"), "VOLCAUSTICS_MI_VARIANT": "cuda_ad_rgb"}
    done = subprocess.run([sys.executable, "-m", "volcaustics", "reference", "refocus", "-o", str(tmp_path / "r.exr"),
                           "--width", "16", "--height", "12", "--photons", "20000", "--spp", "2", "--batches", "2"],
                          capture_output=True, text=True, timeout=300, env=env)
    if done.returncode == 0:
        pytest.skip("CUDA starts on this machine")
    assert done.returncode == 2, done.stderr[-2000:]
    assert "VOLCAUSTICS_MI_VARIANT" in done.stderr and "Traceback" not in done.stderr
