"""Every value the parameter table allows runs or is refused up front:
each parameter's minimum and maximum (a float's close to its open bounds, every choice
of a name) through ``measure`` at a tiny size, in one process. Before, photon_res 1,
steps 32 (no photon alive at a late step) and most extremes at photon_res 8 ended
after the work in "cannot reshape array of size 0" (``metrics.paths``); width 16384
in "width = 65536" (the small-kernel image at 4× per side)."""

from __future__ import annotations

import os

import pytest

from tests.shared import FAST_MEASUREMENT, SINGLE_SCATTERING
from volcaustics.approx.params import PARAMS
from volcaustics.reports.cli import main
from volcaustics.reports.measuring.results.param_input import flag

# tiny: 16×12 pixels, 64 photons (most die before step 4: the empty late steps are the point)
TINY = {"width": 16, "height": 12, "photon_res": 8, "light_res": 16}
REFERENCE = ["--photons", "20000", "--spp", "2", "--batches", "2", "--target-noise", "none", *SINGLE_SCATTERING,
             *FAST_MEASUREMENT]


def extremes(p) -> list:
    """A parameter's minimum and maximum (a float's open range: 1e-6 of it inside), or its choices."""
    if p.choices:
        return list(p.choices)
    if p.kind is float:
        return [p.low + 1e-6 * (p.high - p.low), p.high - 1e-6 * (p.high - p.low)]
    return [p.low, p.high]


CASES = [(p.name, v) for p in PARAMS for v in extremes(p)]


def _entries(cache) -> set:
    """The reference cache's entries."""
    folder = cache / "reference"
    return set(os.listdir(folder)) if folder.is_dir() else set()


def _rendered_here(cache, before: set) -> list:
    """The entries added since ``before`` that this test's measure could have rendered (a
    sphere1 reference of 20,000 photons): the folder is the run's shared one, and tests on
    other workers add their own."""
    import json

    ours = []
    for name in sorted(_entries(cache) - before):
        if name.endswith(".json"):
            manifest = json.loads((cache / "reference" / name).read_text())
            if manifest.get("scene") == "sphere1" and manifest.get("settings", {}).get("photons") == 20000:
                ours.append(name)
    return ours


# nothing alive at a late step must run: these extremes must measure, not be refused
MUST_RUN = {("photon_res", 1), ("steps", 32), ("steps", 1), ("layers", 8), ("iterations", 0)}


@pytest.mark.slow  # about 70 s on 2 shared cores in all, one case a test (so that the workers share them)
@pytest.mark.parametrize("name, value", CASES, ids=[f"{n}={v}" for n, v in CASES])
def test_every_parameter_extreme_measures_or_is_refused_up_front(cache, tmp_path, capsys, name, value):
    """Exit 0 with a summary, or exit 2 naming the parameter and its value with nothing
    rendered (no reference entry added, no output written). Which values are refused
    depends on the machine (memory, GL limits); here: photon_res 8192 and light_res 8192
    (memory, work groups), width/height 1 (below SSIM's window) and 16384 (4× per side
    beyond GL_MAX_TEXTURE_SIZE)."""
    out = tmp_path / "m"
    argv = ["measure", "sphere1", "-o", str(out), "--seeds", "1", "--quiet", *REFERENCE]
    for key, v in {**TINY, name: value}.items():
        argv += [flag(key), str(v)]
    before = _entries(cache)
    code = main(argv)
    err = capsys.readouterr().err
    assert code in (0, 2), (name, value, code, err)
    if code == 0:
        assert (out / "summary.json").is_file(), (name, value)
    else:
        assert (name, value) not in MUST_RUN, (name, value, err)
        assert f"{name} = {value}" in err or f"{name} {value}" in err, (name, value, err)
        assert "Traceback" not in err and not out.exists() and not _rendered_here(cache, before), (name, value, err)
