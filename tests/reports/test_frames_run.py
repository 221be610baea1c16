"""The frame check run end to end on small points (refocus at 32², the gate's small
reference): an interrupted check resumes from the points its result store holds, a
finished one measures nothing again, a point edited by hand is measured again, and a
scene without a caustic is refused after its first point, not measured to NaN for every
configuration and denoiser."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pandas as pd
import pytest

from tests.shared import GATE_REFERENCE
from volcaustics.approx.params import preset
from volcaustics.reports.cli import main
from volcaustics.reports.measuring import runner
from volcaustics.reports.studies.best import frame_check as frames

# the measured frame times (and the ratios of them) differ between two measurements of one point
_TIMES = ["frame_s", "denoise_s", "time_ratio"]


@pytest.fixture
def small(monkeypatch, cache):
    """Small frame-check points, and a count of the points measured (``calls``); the
    measurement raises KeyboardInterrupt at call ``stop_at`` when that is set."""
    state = {"calls": 0, "stop_at": None}
    real = runner.run_experiment

    def counted(*args, **kwargs):
        state["calls"] += 1
        if state["calls"] == state["stop_at"]:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    def params(config, scene_arg, scene=None):
        base = preset("quick" if config == "paper" else config)
        return dataclasses.replace(base, width=32, height=32, photon_res=64, light_res=64)

    monkeypatch.setattr(runner, "run_experiment", counted)
    monkeypatch.setattr(frames, "config_params", params)
    monkeypatch.setattr(frames, "FRAMES_REFERENCE", GATE_REFERENCE)
    return state


def _points(out: Path) -> list:
    """The points the check's result store holds (DIR/points/KEY/)."""
    return sorted(p for p in (out / frames.POINTS).iterdir() if p.is_dir() and not p.name.startswith("."))


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_an_interrupted_frame_check_resumes_and_a_finished_one_measures_nothing(small, tmp_path):
    out = tmp_path / "frames"
    total = len(frames.CONFIGS) * len(frames.usable_denoisers(False))
    small["stop_at"] = 2
    with pytest.raises(KeyboardInterrupt):
        frames.run_frames(["refocus"], str(out), seeds=2, progress=False)
    assert len(_points(out)) == 1                                # the point finished before Ctrl-C is kept
    assert not (out / frames.MANIFEST).exists()                  # and no manifest claims a whole check
    small.update(calls=0, stop_at=None)
    table = frames.run_frames(["refocus"], str(out), seeds=2, progress=False)
    assert small["calls"] == total - 1 and len(table) == total   # only what was missing was measured
    small["calls"] = 0
    again = frames.run_frames(["refocus"], str(out), seeds=2, progress=False)
    assert small["calls"] == 0                                   # a finished check measures nothing
    pd.testing.assert_frame_equal(again, table)
    assert frames.load_frames(str(out))[0].shape == table.shape
    summary = _points(out)[0] / "summary.json"                  # a stored number edited by hand ...
    doc = json.loads(summary.read_text())
    doc["images"]["caustic"]["frame_relative_mse"]["debiased"] /= 100
    summary.write_text(json.dumps(doc))
    small["calls"] = 0
    healed = frames.run_frames(["refocus"], str(out), seeds=2, progress=False)
    assert small["calls"] == 1                                   # ... is measured again, not served
    pd.testing.assert_frame_equal(healed.drop(columns=_TIMES), table.drop(columns=_TIMES))
    small["calls"] = 0
    frames.run_frames(["refocus"], str(out), seeds=3, progress=False)
    assert small["calls"] == total                               # negative control: other seeds, other keys


@pytest.mark.filterwarnings("error::RuntimeWarning")  # no numpy warning on the user's console either
def test_a_scene_without_a_caustic_is_refused_after_its_first_reference(small, tmp_path, capsys):
    """The glass outside the light's beam: exit 2 naming the scene once its first
    point shows the reference's caustic is zero; before, exit 0 with every number NaN
    and a frames.json of bare NaN tokens, each configuration's reference rendered.
    No photon reaches the glass, so the paths' shares are NaN, without numpy's "Mean of
    empty slice"."""
    scene = (Path(__file__).resolve().parents[2] / "scenes" / "builtin" / "refocus.toml").read_text()
    scene = scene.replace('name = "refocus"', 'name = "outside"').split("[animation]")[0]
    scene = scene.replace("translate = [0.0, 1.4, 0.0]", "translate = [3.0, 1.4, 0.0]")
    path = tmp_path / "outside.toml"
    path.write_text(scene)
    out = tmp_path / "frames"
    assert main(["frames", str(path), "-o", str(out), "--seeds", "2", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "outside.toml" in err and "caustic is zero" in err and "Traceback" not in err, err
    assert small["calls"] == 1
    assert not (out / frames.MANIFEST).exists() and not (out / frames.FRAMES_FILE).exists()
