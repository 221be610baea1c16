"""`volcaustics sweep`: specs validated before rendering, a resumable store that loses
nothing on SIGINT and recomputes a damaged point, and a real Dask LocalCluster."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.shared import FAST_MEASUREMENT, SINGLE_SCATTERING
from tests.shared import SWEEP_SPEC as SPEC
from tests.shared import SWEEP_TABLES as SMALL_TABLES
from volcaustics.reports.cli import main
from volcaustics.reports.measuring.results.store import SUMMARY, Store, sealed


@pytest.fixture
def env(cache):
    """The test's cache (its references: the run's shared ones)."""
    return cache


def _spec(tmp_path, text=SPEC, name="sweep.toml") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _complete(store: Path) -> dict:
    """key → mtime of summary.json of every complete point."""
    s = Store(str(store))
    return {p.name: (p / SUMMARY).stat().st_mtime_ns for p in (store / "points").iterdir()
            if not p.name.startswith(".") and s.summary(p.name) is not None}


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_dask_local_cluster_runs_a_sweep_and_writes_tables_and_figures(env, tmp_path, capsys):
    out = tmp_path / "store"
    assert main(["sweep", _spec(tmp_path), "-o", str(out), "--dask", "local:2", "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "4 points: 0 already in the store, 4 computed, 0 failed" in printed
    assert len(_complete(out)) == 4
    points = pd.read_parquet(out / "points.parquet")
    assert sorted(zip(points["layers"], points["iterations"])) == [(1, 4), (1, 8), (2, 4), (2, 8)]
    assert (points["scene"] == "refocus").all() and np.isfinite(points["caustic_relmse_debiased"]).all()
    images = pd.read_parquet(out / "images.parquet")
    assert set(images["point"]) == set(points["point"])
    for name in ("intersection_vs_layers", "intersection_vs_iterations", "caustic_error_vs_layers",
                 "time_vs_error", "power_budget"):
        assert (out / "figures" / f"{name}.png").read_bytes().startswith(b"\x89PNG")
        assert b"<svg" in (out / "figures" / f"{name}.svg").read_bytes()[:500]
    suffice = pd.read_csv(out / "suffice.csv")
    assert set(suffice["parameter"]) == {"layers", "iterations"}
    # warm: everything is in the store, nothing is recomputed
    before = _complete(out)
    assert main(["sweep", _spec(tmp_path), "-o", str(out), "--quiet"]) == 0
    assert "4 already in the store, 0 computed" in capsys.readouterr().out
    assert _complete(out) == before


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_damaged_point_is_detected_and_recomputed(env, tmp_path, capsys):
    out = tmp_path / "store"
    spec = _spec(tmp_path, SPEC.replace("iterations = [4, 8]", "iterations = [4]"))
    assert main(["sweep", spec, "-o", str(out), "--workers", "1", "--quiet"]) == 0
    before = _complete(out)
    assert len(before) == 2
    damaged, kept = sorted(before)
    table = out / "points" / damaged / "images.parquet"
    table.write_bytes(table.read_bytes()[:-100] + b"\0" * 100)  # a torn write
    capsys.readouterr()
    assert main(["sweep", spec, "-o", str(out), "--workers", "1", "--quiet"]) == 0
    assert "1 already in the store, 1 computed" in capsys.readouterr().out
    after = _complete(out)
    assert after[kept] == before[kept] and after[damaged] != before[damaged]
    pd.read_parquet(table)  # whole again


def _interrupted_sweep(tmp_path, *pool) -> tuple:
    """A sweep of 8 points on ``pool`` (its flags) sent SIGINT to its whole process group
    (Ctrl-C at a terminal) once its first point is in the store: (command, store, exit
    code, stderr)."""
    out = tmp_path / "store"
    spec = _spec(tmp_path, SPEC.replace("layers = [1, 2]", "layers = [1, 2, 3, 4]"))  # 8 points
    command = [sys.executable, "-m", "volcaustics", "sweep", spec, "-o", str(out), *pool, "--quiet"]
    # SIGINT as at a terminal: a suite started in the background (nohup, `make test &`) ignores it,
    # and an ignored SIGINT is inherited and respected
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=os.environ.copy(),
                               cwd=Path(__file__).resolve().parents[2], start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 300
    while time.time() < deadline and process.poll() is None:
        if (out / "points").exists() and len(_complete(out)) >= 1:
            break
        time.sleep(0.2)
    assert process.poll() is None, process.communicate()
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=120)
    return command, out, process.returncode, err.decode()


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_sigint_keeps_finished_points_and_the_rerun_computes_only_the_rest(env, tmp_path):
    """SIGINT to the whole process group (Ctrl-C at a terminal) after the first point is
    in the store: exit 130, no partial point and no temporary left (the workers ignore
    SIGINT; the parent stops them and clears their temporaries), and the rerun computes
    exactly the points missing (none twice, none lost)."""
    command, out, code, err = _interrupted_sweep(tmp_path, "--workers", "1")
    assert code == 130, err[-2000:]
    finished = _complete(out)
    assert 1 <= len(finished) < 8
    # no half point and no temporary: every folder is a complete point
    assert sorted(folder.name for folder in (out / "points").iterdir()) == sorted(finished)
    rerun = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy(),
                           cwd=Path(__file__).resolve().parents[2], timeout=600)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    assert f"8 points: {len(finished)} already in the store, {8 - len(finished)} computed" in rerun.stdout
    after = _complete(out)
    assert len(after) == 8
    assert all(after[k] == finished[k] for k in finished)  # none recomputed
    assert not [f for f in (out / "points").iterdir() if f.name.startswith(".")]  # stale temporaries removed


@pytest.mark.slow  # a LocalCluster's start and a few points (about 10 s)
def test_sigint_on_a_local_dask_cluster_ends_in_one_line(env, tmp_path):
    """Ctrl-C on `--dask local:N` exited 130 but printed each worker's KeyboardInterrupt
    traceback; now exit 130 with no traceback, the finished points kept."""
    _, out, code, err = _interrupted_sweep(tmp_path, "--dask", "local:1")
    assert code == 130, err[-2000:]
    assert "Traceback" not in err, err[-3000:]
    assert len(_complete(out)) >= 1


@pytest.mark.parametrize("spec, message", [
    (SPEC.replace("layers = [1, 2]", "layer = [1, 2]"), "unknown parameter 'layer'"),
    (SPEC.replace("layers = [1, 2]", "layers = [1, 99]"), "layers = 99"),
    (SPEC.replace("layers = [1, 2]", "layers = [1, 2.5]"), "expected an integer"),
    (SPEC.replace("seeds = 1", "seeds = 0"), "seeds = 0"),
    (SPEC.replace('scenes = ["refocus"]', 'scenes = ["nosuch"]'), "nosuch"),
    (SPEC + "\n[extra]\n", "unknown key 'extra'"),
    (SPEC.replace("exact_subphotons = 1", "exact_subphotons = 0"), "measurement.exact_subphotons = 0"),
    (SPEC.replace("exact_subphotons = 1", "exact_subfotons = 1"), "measurement.exact_subfotons: unknown"),
    (SPEC.replace("[reference]", "[reference]\nphotonz = 3"), "reference.photonz"),
    ("scenes = [", "not valid TOML"),
])
def test_bad_spec_exits_2_and_renders_nothing(empty_cache, tmp_path, capsys, spec, message):
    out = tmp_path / "store"
    assert main(["sweep", _spec(tmp_path, spec), "-o", str(out), "--quiet"]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()
    assert not empty_cache.exists() or not any(empty_cache.rglob("*.exr"))


@pytest.mark.parametrize("args, message", [
    (["--vary", "layerz=1,2"], "unknown parameter 'layerz'"),
    (["--vary", "layers=1,,2"], "an empty value"),
    (["--vary", "layers=1", "--set", "layers=2"], "both varied and set"),
    (["--set", "fresnel=maybe"], "fresnel"),
    (["--vary", "seed=1,2"], "seed cannot be varied"),
    (["--workers", "0"], "--workers"),
    (["--dask", "udp://x"], "--dask"),
    (["--exact-subphotons", "65"], "--exact-subphotons = 65: expected an integer in [1, 64]"),
    (["--vary", f"iterations={','.join(map(str, range(65)))}", "--vary",  # 16,705 points
      f"peak_samples={','.join(map(str, range(257)))}"], "pass --yes to run it"),
])
def test_bad_command_line_exits_2(env, tmp_path, capsys, args, message):
    out = tmp_path / "store"
    assert main(["sweep", "--scenes", "refocus", *args, "-o", str(out), "--quiet"]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("option", [["--seeds", "1024"], ["--preset", "paper"]])
def test_a_spec_file_with_grid_options_on_the_command_line_exits_2(env, tmp_path, capsys, option):
    """--seeds and --preset beside a SPEC file were silently ignored (the file's own were
    run: seeds 1 for --seeds 1024); they are refused like --set and --vary. (--scenes
    replaces a spec's scenes, grid or best alike: test_scenes_follow_one_rule_in_both_spec_kinds.)"""
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC)
    out = tmp_path / "store"
    assert main(["sweep", str(spec), *option, "-o", str(out), "--quiet"]) == 2
    assert "not both" in capsys.readouterr().err and not out.exists()


def test_an_unreachable_scheduler_is_refused_before_any_reference_renders(empty_cache, tmp_path, capsys):
    import socket

    with socket.socket() as s:  # a port nothing listens on: bound, never listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        out = tmp_path / "store"
        assert main(["sweep", "--scenes", "refocus", "--dask", f"tcp://127.0.0.1:{port}", "-o", str(out),
                     "--quiet"]) == 2
    assert "cannot reach the scheduler" in capsys.readouterr().err
    assert not out.exists() and (not empty_cache.exists() or not any(empty_cache.rglob("*.exr")))


class _Silent(threading.Thread):
    """A TCP server on loopback that accepts and then says nothing (``reply``: or sends
    it, e.g. an HTTP response, and closes)."""

    def __init__(self, reply: bytes | None = None):
        super().__init__(daemon=True)
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.port, self.reply, self.held = self.sock.getsockname()[1], reply, []

    def run(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            if self.reply is None:
                self.held.append(conn)  # open, silent
            else:
                with conn:
                    conn.recv(65536)
                    conn.sendall(self.reply)


@pytest.mark.parametrize("reply, message", [
    (None, "no Dask scheduler answered"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok" * 64, "not a Dask scheduler"),
])
@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_port_that_is_not_a_scheduler_is_refused_in_bounded_time(empty_cache, tmp_path, capsys, reply, message):
    """A port that accepts but never answers once hung the sweep silently; an HTTP server
    ended in numpy's "Unable to allocate 3.07 EiB". Both exit 2 naming the address, within
    the handshake's bound (2 × 5 s)."""
    server = _Silent(reply)
    server.start()
    out = tmp_path / "store"
    t0 = time.perf_counter()
    try:
        assert main(["sweep", "--scenes", "refocus", "--dask", f"tcp://127.0.0.1:{server.port}", "-o", str(out),
                     "--quiet"]) == 2
    finally:
        server.sock.close()
    assert time.perf_counter() - t0 < 30
    err = capsys.readouterr().err
    assert message in err and f"127.0.0.1:{server.port}" in err and "Traceback" not in err and not out.exists()


def _wait_until_it_answers(address: str, deadline: float) -> None:
    """Until a client's handshake with the scheduler at ``address`` succeeds (AssertionError
    at ``deadline``). Each try runs in a thread bounded by the wall clock: the client's own
    timeout does not bound a handshake that never completes (``dask_address`` says the same
    of the sweep's probe), and a try left waiting hung this test for 23 minutes once."""
    from dask.distributed import Client

    while True:
        answered = threading.Event()

        def handshake(answered: threading.Event = answered) -> None:
            try:
                Client(address, timeout="5s", set_as_default=False).close(timeout=5)
                answered.set()
            except Exception:  # noqa: BLE001 (not up yet: whatever the handshake raised)
                pass

        threading.Thread(target=handshake, daemon=True, name="scheduler-handshake").start()
        if answered.wait(12.0):
            return
        assert time.monotonic() < deadline, f"the scheduler at {address} did not answer a handshake"
        time.sleep(0.5)


def test_a_scheduler_without_workers_is_refused_after_the_stated_wait(empty_cache, tmp_path, capsys):
    """A scheduler with no workers: silent for 900 s once; now exit 2 after --dask-wait."""
    file = tmp_path / "scheduler.json"
    scheduler = subprocess.Popen([os.path.join(os.path.dirname(sys.executable), "dask"), "scheduler", "--host",
                                  "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file", str(file)],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(file.read_text())["address"]
        _wait_until_it_answers(address, deadline)  # the file comes before the scheduler answers (a flake in CI)
        out = tmp_path / "store"
        assert main(["sweep", "--scenes", "refocus", "--dask", address, "--dask-wait", "2", "-o", str(out),
                     "--quiet"]) == 2
    finally:
        scheduler.terminate()
        scheduler.wait(30)
    err = capsys.readouterr().err
    assert "no worker after 2 s" in err and "Traceback" not in err and not out.exists()


def test_a_grid_above_the_limit_is_refused_before_it_is_expanded_unless_asked_for():
    """Counted, not expanded: 10^12 points are refused at once (expanding them would never
    end); at or below the limit, or with max_points None (--yes), the spec stands."""
    from volcaustics.reports.studies.sweep.sweep_spec import SweepError, grid_size, spec_from_args

    huge = [f"{name}={','.join(map(str, range(1, 9 if name == 'layers' else 60)))}"
            for name in ("layers", "iterations", "peak_samples", "steps", "fog_steps", "light_res")]
    with pytest.raises(SweepError, match=r"points \(scenes × grid\), more than 10,000.*--yes"):
        spec_from_args("refocus", huge, [], preset="quick", seeds=1)
    with pytest.raises(SweepError, match="3 points"):
        spec_from_args("refocus", ["layers=1,2,3"], [], preset="quick", seeds=1, max_points=2)
    spec = spec_from_args("refocus", ["layers=1,2,3"], [], preset="quick", seeds=1, max_points=None)
    assert grid_size(spec) == 3


def test_store_commit_keeps_a_complete_copy_and_replaces_a_damaged_one(tmp_path):
    """Two writers of one point: the second finds it complete and keeps it; a damaged
    copy in the way is replaced."""
    store = Store(str(tmp_path / "s"))
    key = "k" * 32

    def fake_point(marker):
        tmp = tmp_path / f"tmp-{marker}"
        tmp.mkdir()
        files = {}
        for name in ("segments", "photons", "images"):
            pd.DataFrame({"x": [marker]}).to_parquet(tmp / f"{name}.parquet")
            from volcaustics.infra.storage import file_sha256

            files[f"{name}.parquet"] = file_sha256(str(tmp / f"{name}.parquet"))
        (tmp / SUMMARY).write_text(json.dumps(sealed({"key": key, "files": files})))
        return str(tmp)

    assert store._commit(fake_point(1), key) == "written"
    assert store._commit(fake_point(2), key) == "kept"
    assert pd.read_parquet(Path(store.point_dir(key)) / "images.parquet")["x"].tolist() == [1]
    (Path(store.point_dir(key)) / "photons.parquet").write_bytes(b"garbage")
    assert store.status(key) == "damaged"
    assert store._commit(fake_point(3), key) == "written"
    assert pd.read_parquet(Path(store.point_dir(key)) / "images.parquet")["x"].tolist() == [3]


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_two_sweeps_writing_one_store_do_not_corrupt_it(env, tmp_path):
    """Two sweeps of one spec started together on one store: one runs, the other either
    ran after it or was refused naming the folder (the folder's lock: see the test
    below), every point is there once and whole, and the consolidated tables hold each
    point once."""
    out = tmp_path / "store"
    spec = _spec(tmp_path)
    command = [sys.executable, "-m", "volcaustics", "sweep", spec, "-o", str(out), "--workers", "1", "--quiet"]
    root = Path(__file__).resolve().parents[2]
    # the reference first, so that the two do not render it twice at once (the cache is
    # atomic too, but two renders would only cost time)
    first = _spec(tmp_path, SPEC.replace("iterations = [4, 8]", "iterations = [4]")
                  .replace("layers = [1, 2]", "layers = [1]"), "first.toml")
    assert main(["sweep", first, "-o", str(tmp_path / "warm"), "--quiet"]) == 0
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=os.environ.copy(), cwd=root) for _ in range(2)]
    outputs = [r.communicate(timeout=600) for r in runs]
    codes = sorted(r.returncode for r in runs)
    assert codes in ([0, 0], [0, 2]), [o[1][-1500:] for o in outputs]
    assert all("is writing this folder" in err for (_, err), r in zip(outputs, runs) if r.returncode == 2)
    complete = _complete(out)
    assert len(complete) == 4
    assert not [f for f in (out / "points").iterdir() if f.name.startswith(".") or "damaged" in f.name]
    points = pd.read_parquet(out / "points.parquet")
    assert sorted(points["point"]) == sorted(complete)


@pytest.mark.slow  # a sweep started, killed outright and run again (about 15 s on 2 cores)
def test_a_sweep_into_a_folder_a_live_sweep_holds_is_refused_naming_it(env, tmp_path, capsys):
    """A second sweep into a folder while the first runs: nothing detected it; one of them
    exited 2 with a bogus "figures/….png: No such file or directory" and the other's
    tables were silently replaced. The first holds the folder (an OS lock, for its whole
    run): the second exits 2 at once naming the folder and the first's process, and writes
    nothing there; the first killed outright (SIGKILL: no cleanup ran) leaves no stale
    lock, and the next sweep into the folder runs."""
    out = tmp_path / "store"
    spec = _spec(tmp_path)
    command = [sys.executable, "-m", "volcaustics", "sweep", spec, "-o", str(out), "--workers", "1", "--quiet"]
    first = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=os.environ.copy(),
                             cwd=Path(__file__).resolve().parents[2], start_new_session=True)
    try:
        deadline = time.time() + 300
        while time.time() < deadline and first.poll() is None and not (
                (out / "points").exists() and _complete(out)):
            time.sleep(0.2)
        assert first.poll() is None, first.communicate()
        before = {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()}
        assert main(["sweep", spec, "-o", str(out), "--workers", "1", "--quiet"]) == 2
        err = capsys.readouterr().err
        assert f"-o {out}: a sweep (process {first.pid} on " in err and "is writing this folder" in err, err
        # no table, manifest or figure of its own beside the first's points
        assert {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()} == before
        assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["points"]
    finally:
        os.killpg(first.pid, signal.SIGKILL)  # the sweep and its worker, as a power cut would
        first.communicate(timeout=60)
    assert main(["sweep", spec, "-o", str(out), "--workers", "1", "--quiet"]) == 0
    assert len(pd.read_parquet(out / "points.parquet")) == 4 == len(_complete(out))


def test_a_worker_without_the_sweeps_reference_fails_its_point_with_the_fix(env):
    """Workers never render references: one that does not find the sweep's in its cache
    (another VOLCAUSTICS_CACHE on a cluster node) fails the point and says what to share."""
    from volcaustics.reports.measuring.runner import TASK_VERSION, PointTask, run_point

    task = PointTask(key="0" * 32, key_document={}, scene="refocus", params={}, seeds=1, reference_key="f" * 32,
                     store=str(env.parent / "store"))
    with pytest.raises(RuntimeError, match="VOLCAUSTICS_CACHE"):
        run_point(task)
    # a task of another version (a worker of another volcaustics) is refused, naming both
    with pytest.raises(RuntimeError, match=f"version {TASK_VERSION + 1}.*runs version {TASK_VERSION}"):
        run_point(dataclasses.replace(task, version=TASK_VERSION + 1))


VARIANTS_SPEC = SPEC.replace("""[vary]
layers = [1, 2]
iterations = [4, 8]""", """[[vary]]
search = ["bisection", "hiz"]
[[vary]]
search = ["dda"]
start_rule = ["id"]""")


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_variants_sweep_writes_its_tables_and_figures_and_the_report_shows_it(env, tmp_path, capsys):
    """search / start_rule varied over two grids: variants.csv (the paper's point marked,
    map reads and the intersection term per point), variants_best.csv, the Pareto figure,
    the console table; `report --sweep` with the store shows the Variants table."""
    out = tmp_path / "store"
    assert main(["sweep", _spec(tmp_path, VARIANTS_SPEC), "-o", str(out), "--workers", "1", "--quiet"]) == 0
    assert "variants: per scene the paper's method" in capsys.readouterr().out
    table = pd.read_csv(out / "variants.csv")
    assert sorted(zip(table["search"], table["start_rule"])) == [("bisection", "offset"), ("dda", "id"),
                                                                  ("hiz", "offset")]
    assert table.loc[table["paper"], "search"].tolist() == ["bisection"]  # iterations 30, layers 4, peak 8
    assert (table["map_reads_per_segment"] > 0).all() and np.isfinite(table["share_intersection"]).all()
    best = pd.read_csv(out / "variants_best.csv")
    assert list(best["role"]) == ["paper", "best"]
    assert (out / "figures" / "variants_refocus.png").read_bytes().startswith(b"\x89PNG")
    report = tmp_path / "report"
    assert main(["report", "--scenes", "refocus", "--out", str(report), "--sweep", str(out), "--set", "width=32",
                 "--set", "height=32", "--set", "photon_res=64", "--set", "light_res=64", "--photons", "65536",
                 "--spp", "8", "--batches", "4", "--target-noise", "none", "--seeds", "2", "--quiet",
                 *SINGLE_SCATTERING, *FAST_MEASUREMENT]) == 0
    html = (report / "index.html").read_text()
    assert "id='variants-best'" in html and "variants_refocus" in html


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_later_sweep_into_the_same_folder_leaves_no_output_of_the_earlier(env, tmp_path, capsys):
    """A variants sweep, then one over layers into the same folder: variants.csv,
    variants_best.csv and the variants figure of the first stayed beside the second's
    sweep.json, and an interrupted second run left all of the first's figures
    (hostile pass). The earlier run's figures and variant tables go before the new set."""
    out = tmp_path / "store"
    assert main(["sweep", _spec(tmp_path, VARIANTS_SPEC), "-o", str(out), "--workers", "1", "--quiet"]) == 0
    assert (out / "variants.csv").exists() and (out / "figures" / "variants_refocus.png").exists()
    layers = tmp_path / "layers.toml"
    layers.write_text(SPEC.replace("iterations = [4, 8]\n", ""))
    assert main(["sweep", str(layers), "-o", str(out), "--workers", "1", "--quiet"]) == 0
    assert not (out / "variants.csv").exists() and not (out / "variants_best.csv").exists()
    assert not list((out / "figures").glob("variants_*")) and list((out / "figures").glob("*.png"))


@pytest.mark.parametrize("args, message", [
    (["--vary", "medium.sigma_s=-1,0.2"], "medium.sigma_s = -1"),
    (["--vary", "medium.sigma_z=0.1"], "unknown key"),
    (["--vary", "fog.density=1"], "TABLE one of"),
    (["--set", "specular.4.ior=1.2"], "specular object"),
    (["--vary", "specular.².ior=1.5"], "give its index"),       # a superscript is not an index
    (["--vary", "medium.sigma_s={a=1}"], "a number, a word or a list"),
    (["--vary", "camera.width=64,128"], "--set width=N"),       # the size is a parameter
    (["--vary", "sigma_s=0.1"], "medium.sigma_s"),              # the hint names the scene fields
])
def test_bad_scene_fields_exit_2_naming_the_key(env, tmp_path, capsys, args, message):
    out = tmp_path / "store"
    assert main(["sweep", "--scenes", "refocus", *args, "-o", str(out), "--quiet"]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_a_density_sweep_reads_the_model_term_against_optical_depth(env, tmp_path, capsys):
    """Two densities of one scene with 2 scattering orders: the scene fields and the
    optical depth are columns, the model's own error is measured at each point and grows
    with the density, and the figure and the crossing table are written."""
    spec = """
scenes = ["refocus"]
seeds = 2
[[vary]]
"medium.sigma_s" = [0.05]
"medium.sigma_a" = [0.005]
[[vary]]
"medium.sigma_s" = [0.4]
"medium.sigma_a" = [0.04]
""" + SMALL_TABLES.replace("max_scatter = 1", "max_scatter = 2")  # the model term under test
    out = tmp_path / "store"
    assert main(["sweep", _spec(tmp_path, spec), "-o", str(out), "--quiet"]) == 0
    points = pd.read_parquet(out / "points.parquet").sort_values("optical_depth")
    assert list(points["medium.sigma_s"]) == [0.05, 0.4] and list(points["medium.sigma_a"]) == [0.005, 0.04]
    assert points["optical_depth"].iloc[1] == pytest.approx(8 * points["optical_depth"].iloc[0])
    own = points["model_combined_relmse_own"].to_numpy()
    assert np.all(np.isfinite(own)) and own[1] > own[0]
    assert (out / "figures" / "model_vs_optical_depth.png").exists()
    crossing = pd.read_csv(out / "model_crossing.csv")
    assert set(crossing["component"]) == {"caustic", "combined"}
    assert "single-scattering model: the optical depth" in capsys.readouterr().out


@pytest.mark.parametrize("table, message", [
    ('[vary]\nmedium.sigma_s = [0.1, 0.2]', '"medium.sigma_s" = ...'),   # unquoted: TOML made it a table
    ('[vary]\n"medium.sigma_s" = [[[0.1], [0.2], [0.3]]]', "a number, a word or a list"),
    ('[set]\n"specular.0.transform" = { translate = [0, 1, 0] }', "a number, a word or a list"),
])
def test_bad_scene_fields_in_a_spec_exit_2(env, tmp_path, capsys, table, message):
    out = tmp_path / "store"
    spec = 'scenes = ["refocus"]\n' + table + "\n"
    assert main(["sweep", _spec(tmp_path, spec), "-o", str(out), "--quiet"]) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_rgb_scene_fields_in_a_spec_and_the_scenes_own_values():
    """An RGB list in a spec reaches the scene (the loader reads TOML arrays); a field one
    grid varies keeps the scene's own value in the others (a column, never NaN)."""
    from volcaustics.reports.measuring.runner import point_scene
    from volcaustics.reports.studies.sweep.sweep_spec import SweepSpec, points

    spec = SweepSpec(("refocus",), (("medium.sigma_s", ((0.1, 0.2, 0.3),)), ("layers", (1, 2))),
                     grids=((("medium.sigma_s", ((0.1, 0.2, 0.3),)),), (("layers", (1, 2)),)))
    made = points(spec)
    assert point_scene(made[0].scene, made[0].fields).medium.sigma_s == (0.1, 0.2, 0.3)
    assert all(dict(p.fields)["medium.sigma_s"] == (0.2, 0.2, 0.2) for p in made[1:])  # refocus's own


def test_a_point_dask_cancelled_says_its_worker_was_lost():
    """When the last worker died, points failed with "FutureCancelledError … already
    forgotten", which did not say a worker died; the failure line now does. Another
    error keeps its own type and message (the negative control)."""
    from distributed.client import FutureCancelledError

    from volcaustics.reports.measuring.pools.executors import describe_failure

    lost = describe_failure(FutureCancelledError("volcaustics-point-abc", reason="already forgotten"))
    assert "lost with its worker" in lost and "already forgotten" in lost
    assert describe_failure(ValueError("reference caustic is zero")) == "ValueError: reference caustic is zero"
