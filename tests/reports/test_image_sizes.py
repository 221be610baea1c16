"""Image sizes are checked up front against the GL driver's limits and this machine's
memory: 8192² and 16384² ended in allocation or GL tracebacks (or, in
measure, "width = 65536" after the work); now every command refuses them with exit 2
naming the value, the limit and what fits, before anything renders."""

from __future__ import annotations

import time

import pytest

from volcaustics.approx.limits import IMAGE_BYTES_PER_PIXEL, check_fits, check_image_fits
from volcaustics.approx.params import ApproxParams, ParamError
from volcaustics.infra.memory import memory_budget
from volcaustics.reference.settings import IMAGE_BYTES_PER_PIXEL as REFERENCE_BYTES_PER_PIXEL
from volcaustics.reference.settings import ReferenceSettings, SettingsError
from volcaustics.reports.cli import main


def test_the_gl_limit_counts_the_pixels_drawn_per_side():
    check_image_fits(64, 48, max_size=64)
    check_image_fits(16, 12, max_size=64, supersample=4)
    with pytest.raises(ParamError, match=r"width = 65: the image is 65 pixels, .*\(64\); width ≤ 64 fits"):
        check_image_fits(65, 48, max_size=64)
    with pytest.raises(ParamError, match=r"height = 17: the image drawn at 4× per side is 68 pixels.*height ≤ 16"):
        check_image_fits(16, 17, max_size=64, supersample=4)
    # unset width/height (the scene camera's, resolved later) is checked when resolved
    check_fits(ApproxParams(photon_res=8, light_res=16), max_groups=1 << 20, max_size=1)


def test_memory_names_the_need_the_budget_and_what_fits():
    side = int((memory_budget() / IMAGE_BYTES_PER_PIXEL) ** 0.5) + 1
    with pytest.raises(ParamError, match=rf"width × height = {side} × {side}: the approximation's image buffers "
                                         r"need .* GiB, more than half of this machine's memory .* fits"):
        check_image_fits(side, side, max_size=1 << 30)
    check_image_fits(side - 2, side - 2, max_size=1 << 30)
    side = int((memory_budget() / REFERENCE_BYTES_PER_PIXEL) ** 0.5) + 1
    if side > 16384:
        pytest.skip("this machine holds a 16384² reference")
    with pytest.raises(SettingsError, match=rf"{side} × {side}: the reference's film and layers need"):
        ReferenceSettings(width=side, height=side)


def _commands(tmp_path, size):
    s = str(size)
    sets = ["--set", f"width={s}", "--set", f"height={s}"]
    return {
        "approx": ["approx", "sphere1", "-o", str(tmp_path / "a.exr"), "--width", s, "--height", s],
        "reference": ["reference", "sphere1", "-o", str(tmp_path / "r.exr"), "--width", s, "--height", s],
        "measure": ["measure", "sphere1", "-o", str(tmp_path / "m"), "--width", s, "--height", s, "--quiet"],
        "sweep": ["sweep", "-o", str(tmp_path / "s"), "--scenes", "sphere1", *sets, "--vary", "layers=1,2",
                  "--quiet"],
        "gate": ["gate", "--out", str(tmp_path / "g"), "--scenes", "sphere1", *sets, "--render-references",
                 "--quiet"],
        "report": ["report", "--out", str(tmp_path / "p"), "--scenes", "sphere1", *sets, "--quiet"],
    }


@pytest.mark.parametrize("size", [8192, 16384])
def test_every_command_refuses_an_image_beyond_the_machine_before_rendering(tmp_path, capsys, size, empty_cache):
    """At these sizes the measuring commands draw 4× per side (beyond any GL driver's
    32768) and hold kilobytes per pixel; approx and reference hold IMAGE_BYTES_PER_PIXEL."""
    beyond = {"approx": size * size * IMAGE_BYTES_PER_PIXEL > memory_budget(),
              "reference": size * size * REFERENCE_BYTES_PER_PIXEL > memory_budget()}
    for command, argv in _commands(tmp_path, size).items():
        if not beyond.get(command, True):
            continue  # this machine holds it: rendering it is no tiny test
        t0 = time.perf_counter()
        assert main(argv) == 2, command
        err = capsys.readouterr().err
        assert time.perf_counter() - t0 < 30.0, command  # nothing rendered
        assert f"{size}" in err and "fits" in err and "Traceback" not in err, (command, err)
        assert not (tmp_path / "cache" / "reference").exists(), command  # no reference rendered
        outputs = [p.name for p in tmp_path.iterdir() if p.name != "cache"]
        assert not outputs, (command, outputs)
