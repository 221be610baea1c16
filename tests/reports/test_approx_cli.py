"""`volcaustics approx`: one multi-layer EXR, PNG preview, segment records, timings JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.shared import BASE_SCENE
from volcaustics.infra.imageio import read_exr
from volcaustics.reports.cli import main
from volcaustics.scenes.formats import LAYER_NAMES, STATUS_COLLIDED, STATUS_SURFACE


def test_approx_cli_outputs(tmp_path, capsys):
    out = tmp_path / "r.exr"
    rc = main(["approx", "refocus", "--preset", "quick", "--photon-res", "96", "--width", "48", "--height", "40",
               "--light-res", "128", "--steps", "3", "-o", str(out)])
    assert rc == 0
    layers, header = read_exr(str(out))
    assert set(layers) == set(LAYER_NAMES)
    # viewers open on the beauty image: `combined` is also the root R, G, B (as Mitsuba's AOV films write it)
    import OpenEXR

    with OpenEXR.File(str(out), separate_channels=True) as exr:
        root = {c: np.asarray(exr.channels()[c].pixels) for c in "RGB"}
    assert all(np.array_equal(root[c], layers["combined"][..., k]) for k, c in enumerate("RGB"))
    assert layers["combined"].shape == (40, 48, 3)
    assert np.allclose(layers["combined"], layers["caustic"] + layers["fog"] + layers["direct"], rtol=1e-6, atol=1e-9)
    assert set(np.unique(layers["mask_specular"])) <= {0.0, 1.0} and layers["mask_specular"].max() == 1.0
    params = json.loads(header["volcaustics_params"])
    assert params["photon_res"] == 96 and params["steps"] == 3 and params["layers"] == 4
    summary = json.loads((tmp_path / "r.json").read_text())
    assert summary["params"] == params and summary["timing_method"] in ("gl_timer_query", "finish_wall_clock")
    assert {"layers", "emission", "trace", "splat", "fog", "direct"} <= set(summary["timings_s"])
    assert all(v >= 0 for v in summary["timings_s"].values())
    assert (tmp_path / "r.png").read_bytes().startswith(b"\x89PNG")
    data = np.load(tmp_path / "r.records.npz")
    recs = data["records"]
    assert set(np.unique(recs["step"])) == {1, 2, 3}
    # A hit's end point is start + t·direction; a collision's is start + max_length·direction.
    hit = recs["hit"] & (recs["status"] == STATUS_SURFACE)
    assert hit.any()
    assert np.allclose(recs["end"][hit], recs["start"][hit] + recs["t"][hit, None] * recs["direction"][hit], atol=1e-4)
    col = recs["status"] == STATUS_COLLIDED
    assert col.any()
    assert np.allclose(recs["end"][col], recs["start"][col] + recs["max_length"][col, None] * recs["direction"][col],
                       atol=1e-4)
    assert "approx refocus" in capsys.readouterr().out
    assert not list(tmp_path.glob(".*tmp*"))


def test_bad_parameter_exits_2(tmp_path, capsys):
    assert main(["approx", "refocus", "--layer-strategy", "peel", "--peak-samples", "-1", "-o",
                 str(tmp_path / "x.exr")]) == 2
    err = capsys.readouterr().err
    assert "peak_samples = -1" in err and "Traceback" not in err
    assert not (tmp_path / "x.exr").exists()


def test_an_upper_case_extension_is_kept(tmp_path, capsys):
    """`-o shot.EXR` writes shot.EXR and its siblings after the stem, not shot.exr."""
    assert main(["approx", "refocus", "--preset", "quick", "--photon-res", "32", "--light-res", "32", "--width", "16",
                 "--height", "16", "-o", str(tmp_path / "shot.EXR")]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["shot.EXR", "shot.json", "shot.png", "shot.records.npz"]
    assert json.loads((tmp_path / "shot.json").read_text())["outputs"]["exr"].endswith("shot.EXR")


def test_a_preset_that_resizes_the_scenes_camera_says_so(tmp_path, capsys, write_scene):
    """The presets set width and height: a 96 × 54 scene file rendered 256 × 256 (another
    aspect, a narrower view) without a word. It is said on the console, with the flags that
    keep the scene's size; given those flags, nothing is said."""
    text = open(write_scene()).read().replace("width = 64", "width = 96").replace("height = 48", "height = 54")
    scene = tmp_path / "wide.toml"
    scene.write_text(text)
    small = ["--photon-res", "16", "--light-res", "16", "--fog-steps", "4", "--steps", "1"]
    assert main(["approx", str(scene), "--preset", "quick", *small, "-o", str(tmp_path / "q.exr")]) == 0
    err = capsys.readouterr().err
    assert "256 × 256" in err and "96 × 54" in err and "--width 96 --height 54" in err, err
    assert read_exr(str(tmp_path / "q.exr"))[0]["combined"].shape == (256, 256, 3)  # the preset's size, as said
    assert main(["approx", str(scene), "--preset", "quick", *small, "--width", "96", "--height", "54",
                 "-o", str(tmp_path / "s.exr")]) == 0
    assert "note" not in capsys.readouterr().err
    assert read_exr(str(tmp_path / "s.exr"))[0]["combined"].shape == (54, 96, 3)


# BASE_SCENE under a 6° spot, seen at 96²
NARROW_SPOT = (BASE_SCENE.replace("cutoff_angle = 25.0", "cutoff_angle = 6.0")
               .replace("beam_width = 20.0", "beam_width = 5.0").replace("width = 64", "width = 96")
               .replace("height = 48", "height = 96"))


def test_a_beams_frame_passes_compares_own_input_check(tmp_path, write_scene):
    """The preset beams on a narrow spot (6°): most of the image lies beyond every beam's
    kernel, where beams carrying their own σ average the kernel over each pixel by a
    second difference in float32 (splat/beam.frag.glsl). It cancelled to pixels of
    −1e-13 beside a peak of 0.018 (3 of 96², photon_res 64), and compare, reading the
    harness's own EXR, refused it (exit 2: radiance is ≥ 0). The frame's caustic is ≥ 0
    with pixels of exactly 0, and compare's input check reads it."""
    from volcaustics.reports.studies.compare.comparison_inputs import read_images
    from volcaustics.scenes import resolve_scene

    path = write_scene(NARROW_SPOT)
    out = str(tmp_path / "beams.exr")
    assert main(["approx", path, "--preset", "beams", "--photon-res", "64", "--width", "96", "--height", "96",
                 "-o", out]) == 0
    inputs = read_images([out], resolve_scene(path))  # CompareError on a negative pixel
    assert inputs.components and not inputs.warnings
    caustic = read_exr(out)[0]["caustic"]
    assert caustic.min() == 0.0 and caustic.max() > 0


@pytest.mark.parametrize("flags", [["--preset", "beams", "--splat-radius", "1e-38"],
                                   ["--preset", "quick", "--splat", "density", "--splat-radius", "1e-38"],
                                   ["--preset", "quick", "--splat-radius", "1e-30"],
                                   ["--preset", "beams", "--splat-footprints", "1e-38"],
                                   ["--preset", "quick", "--splat-radius", "9.9999999999"]])
def test_a_float_parameter_float32_cannot_hold_exits_2_naming_it(tmp_path, capsys, flags):
    """splat_radius 1e-38 was inside (0, 10) in float64: the beams' and density splats'
    caustic came out mostly NaN, 1e-30 all 0, both written with exit 0. A float's range
    now holds in float32 (approx.params.FLOAT32_FLOOR, and the value rounded to float32:
    9.9999999999 is 10 there): exit 2 naming the parameter, nothing written."""
    out = tmp_path / "x.exr"
    code = main(["approx", "refocus", *flags, "--photon-res", "32", "--width", "16", "--height", "16",
                 "-o", str(out)])
    err = capsys.readouterr().err
    name = flags[-2].lstrip("-").replace("-", "_")
    assert code == 2 and f"{name} = {float(flags[-1])!r}" in err and "(1e-06, " in err, err
    assert not list(tmp_path.iterdir())


def test_a_frame_float32_cannot_hold_is_refused_before_it_is_written(ctx, tmp_path):
    """The check behind the bounds (approx.frame_checks): with a table that still allows
    splat_radius 1e-38 (a parameter being added, approx.params.params_class), the beams
    frame is NaN; `approx` refuses it naming the layer and the float parameters, and
    writes none of its files; `measure`'s frames are refused the same way before any
    metric reads them."""
    import dataclasses

    from volcaustics.approx import Renderer
    from volcaustics.approx.frame_checks import NonFiniteFrame
    from volcaustics.approx.params import PARAMS, PRESETS, params_class
    from volcaustics.experiment.approx_frames import render_frames
    from volcaustics.reports.presenting.exports.approx_files import run_approx
    from volcaustics.scenes import resolve_scene

    loose = params_class(tuple(dataclasses.replace(p, low=0.0) if p.name == "splat_radius" else p for p in PARAMS))
    params = loose(**{**PRESETS["beams"].to_dict(), "photon_res": 32, "light_res": 32, "width": 16, "height": 16,
                      "splat_radius": 1e-38})
    scene = resolve_scene("refocus")
    with pytest.raises(NonFiniteFrame, match=r"caustic layer has \d+ pixel\(s\) with NaN .* splat_radius = 1e-38"):
        run_approx(scene, params, str(tmp_path / "x.exr"))
    assert not list(tmp_path.iterdir())
    renderer = Renderer(scene)
    try:
        with pytest.raises(NonFiniteFrame, match="seed 0.*splat_radius = 1e-38"):
            render_frames(renderer, scene, params, [0], warm_up=False)
    finally:
        renderer.release()
