"""A cached reference served to a run that asked for another target or caps
(``reference.served``): the run's summary judges it against its own request and says that
it was rendered for another; a photon cap that could never stop a render is refused."""

from __future__ import annotations

import json

import pytest

from tests.shared import FAST_MEASUREMENT, SINGLE_SCATTERING
from volcaustics.reference.settings import ReferenceSettings, SettingsError
from volcaustics.reports.cli import main

# refocus at 32², a 4-batch single-scattering reference of 2^14 photons a batch: milliseconds a batch
MEASURE = ["measure", "refocus", "--seeds", "2", "--quiet", "--width", "32", "--height", "32", "--photon-res", "64",
           "--light-res", "64", "--photons", "65536", "--spp", "8", "--batches", "4", *SINGLE_SCATTERING,
           *FAST_MEASUREMENT]
REFERENCE = ["reference", "refocus", "--width", "32", "--height", "32", "--photons", "65536", "--spp", "8",
             "--batches", "4"]
# a target no render meets: its time cap stops it (the first request)
UNREACHABLE = ["--target-noise", "fog=1e-300", "--max-seconds", "1"]


def test_a_served_reference_is_judged_against_this_runs_target(empty_cache, tmp_path, capsys):
    """After a run whose reference stopped at its time cap short of fog = 1e-300, a run
    asking 10% is served that entry (it meets 10%): its summary says "target", nothing
    short, names the request it was rendered for, and is a point of its own in the store
    (the request is in its key), not the first run's summary read back."""
    assert main([*MEASURE, *UNREACHABLE, "-o", str(tmp_path / "first")]) == 0
    first = json.loads((tmp_path / "first" / "summary.json").read_text())
    assert first["reference"]["stopped_by"] == "time cap" and first["reference"]["rendered_for"] is None
    capsys.readouterr()
    assert main([*MEASURE, "--target-noise", "0.1", "-o", str(tmp_path / "second")]) == 0
    printed = capsys.readouterr().out
    second = json.loads((tmp_path / "second" / "summary.json").read_text())
    ref = second["reference"]
    assert ref["key"] == first["reference"]["key"] and ref["cached"]  # the same entry, served
    assert ref["stopped_by"] == "target" and ref["short_of_target"] == {}
    assert ref["request"]["target_noise"]["fog"] == 0.1
    assert ref["rendered_for"]["target_noise"] == {"fog": 1e-300} and ref["rendered_for"]["max_seconds"] == 1
    assert not any("time cap" in w for w in second["warnings"]), second["warnings"]
    assert any("rendered for another request" in w and "target fog 1e-298%" in w for w in second["warnings"])
    assert "from the store" not in printed and second["key"] != first["key"]


def test_the_reference_command_judges_a_served_entry_against_its_request(empty_cache, tmp_path, capsys):
    out = tmp_path / "r.exr"
    assert main([*REFERENCE, *UNREACHABLE, "-o", str(out)]) == 0
    assert "stopped by time cap" in capsys.readouterr().out
    assert main([*REFERENCE, "--target-noise", "0.5", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "stopped by target; rendered for another request: target fog 1e-298%" in printed, printed
    served = json.loads((tmp_path / "r.json").read_text())["served_to"]
    assert served["stopped_by"] == "target" and served["request"]["target_noise"]["caustic"] == 0.5


# below one batch (2^14 photons); below the 4 batches every render draws
@pytest.mark.parametrize("cap", ["1", "65535"])
def test_a_photon_cap_below_what_every_render_draws_is_refused(empty_cache, tmp_path, capsys, cap):
    """With a noise target the photon cap limits the batches the target adds beyond the
    first ``batches``; a cap below them could never stop anything (it passed silently)."""
    with pytest.raises(SettingsError, match=f"max_photons = {cap}: below the 65,536 photons"):
        ReferenceSettings(photons=65536, batches=4, target_noise=0.1, max_photons=int(cap))
    for command in (MEASURE, REFERENCE):
        out = tmp_path / ("m" if command is MEASURE else "r.exr")
        assert main([*command, "--target-noise", "0.1", "--max-photons", cap, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"max_photons = {cap}: below the 65,536 photons" in err and "Traceback" not in err, err
    assert not empty_cache.exists() or not any(empty_cache.rglob("*.exr"))  # refused before anything rendered
    ReferenceSettings(photons=65536, batches=4, target_noise=0.1, max_photons=65536)  # the least cap that can stop one
    ReferenceSettings(photons=65536, batches=4, max_photons=1)  # no target: no cap to apply
