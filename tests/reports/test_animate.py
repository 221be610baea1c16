"""`volcaustics animate`: real renders over time (the approximation through one
Renderer, Mitsuba references per frame), the flicker metric's calibration and its
negative control, the files it writes, resuming, and bad input."""

from __future__ import annotations

import dataclasses
import json
import shutil

import numpy as np
import pandas as pd
import pytest

from volcaustics.metrics.temporal import flicker
from volcaustics.reference.render import render_reference
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.cli import main
from volcaustics.reports.studies.animate.animation_settings import frame_list, reference_seed
from volcaustics.scenes import load_builtin
from volcaustics.scenes.catalogue import builtin_path

SIZE = 32
FRAMES = 4  # refocus frames 0-3: the sphere rises 0.05 m per frame
# few photons (32² slots) so that the approximation's own noise is plain to see
ARGS = ["--width", str(SIZE), "--height", str(SIZE), "--photon-res", "32", "--light-res", "64", "--frames",
        f"0:{FRAMES}", "--photons", str(1 << 18), "--spp", "8", "--batches", "8", "--quiet"]


def test_reference_flicker_against_an_independent_reference_is_within_noise(cache):
    """Two references of the same frames with different seeds (each frame its own,
    ``reference_seed``): every component's flicker, less both references' variances, within
    4 SE of 0 on every pair (the z-test the metric's debiasing promises). With one seed for
    every frame this failed: z −4.5 (caustic) to −8.7 (fog), the frames' noise correlated."""
    scene = load_builtin("refocus")
    frames = [scene.animation.scene_at(scene, t) for t in range(FRAMES)]
    runs = []
    for seed in (0, 1):
        settings = ReferenceSettings(photons=1 << 18, spp=8, batches=8, width=SIZE, height=SIZE)
        runs.append([render_reference(f, dataclasses.replace(settings, seed=reference_seed(seed, t)))
                     for t, f in enumerate(frames)])
    zs = {}
    for component in ("caustic", "fog", "direct"):
        first, second = ([np.stack([r.mean[component] for r in rs]), np.stack([r.var[component] for r in rs])]
                         for rs in runs)
        pairs = flicker(first[0], first[1], second[0][None], test_var=second[1])
        zs[component] = [round(p.z, 2) for p in pairs]
    print("z per component and pair", zs)
    assert all(abs(z) < 4 for values in zs.values() for z in values), zs


def _brightening(tmp_path) -> str:
    """refocus with its light brightening 10 → 13 W/sr over 4 frames: with one seed the
    approximation's frames are exactly proportional (the pipeline is linear in the
    intensity), so its noise cannot flicker; with a new seed every frame it does."""
    text = open(builtin_path("refocus"), encoding="utf-8").read().split("[animation]")[0]
    text += ('[animation]\nframes = 4\nfps = 8\n\n[[animation.track]]\npath = "light.intensity"\n'
             'frame = [0, 3]\nvalue = [10.0, 13.0]\n')
    path = tmp_path / "brightening.toml"
    path.write_text(text)
    return str(path)


@pytest.mark.slow  # end to end, several points (10-50 s on 2 cores): `make test-fast` skips it
def test_animate_writes_the_set_and_a_new_seed_per_frame_flickers_more(cache, tmp_path):
    """End to end at 32² with 32² photons: the tables, the MP4 (imageio reads back the
    frame count), the WebP, the plot and the summary. The metric's negative control: a
    new seed every frame makes the caustic flicker more than one fixed seed, by more than
    4 SE of the difference (measured: 0.33% ± 0.07 against 79% ± 10). A second run
    reads every undamaged frame back instead of rendering it (a damaged frame file is
    rendered again: it raised BadZipFile before; so is one of the right key with arrays of
    the wrong shape) and writes the same tables."""
    out = tmp_path / "anim"
    scene = _brightening(tmp_path)
    assert main(["animate", scene, "-o", str(out), *ARGS]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == list(range(FRAMES)) and summary["seed_modes"] == ["fixed", "per-frame"]
    video_metric = summary["perceptual_video_metric"]  # ColorVideoVDP: skipped, never silently
    assert video_metric["measured"] is False and "PyTorch" in video_metric["reason"]
    temporal = pd.read_parquet(out / "temporal.parquet")
    frames = pd.read_parquet(out / "frames.parquet")
    assert set(frames["frame"]) == set(range(FRAMES)) and set(frames["seed_mode"]) == {"fixed", "per-frame"}
    caustic = {m: summary["metrics"][m]["caustic"] for m in ("fixed", "per-frame")}
    print("caustic flicker", {m: (c["flicker"], c["flicker_se"]) for m, c in caustic.items()})
    gap = caustic["per-frame"]["flicker"] - caustic["fixed"]["flicker"]
    assert gap > 4 * np.hypot(caustic["per-frame"]["flicker_se"], caustic["fixed"]["flicker_se"])
    pairs = temporal[(temporal["component"] == "caustic") & temporal["flicker"].notna()]
    assert len(pairs) == 2 * (FRAMES - 1)

    import imageio.v2 as imageio
    from PIL import Image

    with imageio.get_reader(str(out / "animation.mp4")) as reader:
        assert reader.count_frames() == FRAMES
    web = out / summary["video"]["web"]
    with Image.open(web) as image:
        assert image.n_frames == FRAMES
    assert (out / "timeseries.png").stat().st_size > 0

    # one summary per animation: the result store's, byte for byte the one in DIR
    stored = cache / "report-results" / "animations" / summary["key"]
    written = (out / "summary.json").read_bytes()
    assert (stored / "summary.json").read_bytes() == written
    (out / ".animate" / "frame-0002.npz").write_bytes(b"PK\x03\x04 damaged")  # a damaged frame: rendered again
    # the right key over arrays of the wrong shape: a ValueError traceback before, now rendered again
    with np.load(out / ".animate" / "frame-0001.npz") as data:
        arrays = {k: data[k][:, :16] if k.endswith("/caustic") else data[k] for k in data.files}
    np.savez(out / ".animate" / "frame-0001.npz", **arrays)
    other = tmp_path / "other"  # a second run, into another folder: read from the store, nothing rendered
    assert main(["animate", scene, "-o", str(other), *ARGS]) == 0
    assert (other / "summary.json").read_bytes() == written and not (other / ".animate").exists()
    shutil.rmtree(stored)  # without the stored set: measured again, its undamaged frames read back from DIR
    assert main(["animate", scene, "-o", str(out), *ARGS]) == 0
    again = json.loads((out / "summary.json").read_text())
    assert again["seconds"]["frames_resumed"] == FRAMES - 2
    assert again["seconds"]["references_cached"] == FRAMES
    pd.testing.assert_frame_equal(pd.read_parquet(out / "temporal.parquet"), temporal)
    # another --frames selection reuses the frames it shares with the runs before
    assert main(["animate", scene, "-o", str(out), *[a if a != f"0:{FRAMES}" else "1:3" for a in ARGS]]) == 0
    assert json.loads((out / "summary.json").read_text())["seconds"]["frames_resumed"] == 2


@pytest.mark.slow  # end to end, one animation of 2 frames at 32² (about 10 s)
def test_a_stored_animation_edited_is_measured_again_and_refused_by_the_report(cache, tmp_path):
    """The stored set's seal: a number edited in the store's summary.json makes animate
    measure the animation again rather than copy the edited number out; one edited in DIR
    is refused by `report --animation DIR` (exit 2, naming the edit; it was drawn before),
    as is a plot replaced."""
    from volcaustics.infra.errors import InputError
    from volcaustics.reports.studies.animate.animation_read import load_animation

    out = tmp_path / "anim"
    args = [a if a != f"0:{FRAMES}" else "0:2" for a in ARGS]
    assert main(["animate", "refocus", "-o", str(out), *args]) == 0
    first = json.loads((out / "summary.json").read_text())
    assert load_animation(str(out)).scene == "refocus"
    stored = cache / "report-results" / "animations" / first["key"] / "summary.json"
    text = stored.read_text()
    edited = text.replace(f'"chains": {first["chains"]}', f'"chains": {first["chains"] + 1}', 1)
    assert edited != text
    stored.write_text(edited)
    assert main(["animate", "refocus", "-o", str(out), *args]) == 0
    again = json.loads((out / "summary.json").read_text())
    assert again["chains"] == first["chains"] and again["seconds"]["frames_resumed"] == 2  # measured again
    assert stored.read_bytes() == (out / "summary.json").read_bytes()
    (out / "summary.json").write_text(edited)
    with pytest.raises(InputError, match="summary.json was edited after it was written"):
        load_animation(str(out))
    shutil.copyfile(stored, out / "summary.json")
    (out / "timeseries.png").write_bytes(b"\x89PNG another plot")
    with pytest.raises(InputError, match="timeseries.png is not the file it was written as"):
        load_animation(str(out))


@pytest.mark.slow  # every built-in animation, 3 frames at 32² (about 40 s)
@pytest.mark.parametrize("name", ["bunny", "refocus", "two_spheres"])
def test_builtin_animations_run(cache, tmp_path, name):
    out = tmp_path / name
    args = [a if a != f"0:{FRAMES}" else "3" for a in ARGS]  # 3 frames spread over the animation
    assert main(["animate", name, "-o", str(out), *args]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == [0, 12, 23]
    for mode in ("fixed", "per-frame"):
        assert np.isfinite(summary["metrics"][mode]["combined"]["flicker"])


def test_a_bad_animation_table_exits_2_naming_the_key(cache, tmp_path, capsys):
    """`animate` reads the scene with the loader: a bad [animation] key exits 2 naming it."""
    text = open(builtin_path("refocus"), encoding="utf-8").read().replace('path = "specular.sphere.translate"',
                                                                          'path = "specular.ball.translate"')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    assert main(["animate", str(path), "-o", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "animation.track[0].path" in err and "specular.ball.translate" in err and "Traceback" not in err


@pytest.mark.parametrize("args,named", [
    (["sphere1"], "no [animation]"),
    (["refocus", "--frames", "5:2"], "--frames"),
    (["refocus", "--frames", "0"], "--frames"),
    (["refocus", "--frames", "0:100"], "frames 0 … 23 only"),  # was cut to 0–23 without a word
    (["refocus", "--chains", "0"], "--chains"),
])
def test_bad_input_exits_2_naming_it(cache, tmp_path, capsys, args, named):
    assert main(["animate", *args, "-o", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert named in err and "Traceback" not in err
    assert not (tmp_path / "out" / "summary.json").exists()


@pytest.mark.parametrize("text,frames,expected", [
    ("4", 24, [0, 8, 15, 23]),
    ("24", 24, list(range(24))),
    ("30", 24, list(range(24))),   # more than the animation has: every frame
    ("100", 3, [0, 1, 2]),
    ("1", 24, [0]),
    ("2:6:2", 24, [2, 4]),
    ("-3:", 24, [21, 22, 23]),
])
def test_frame_list_spans_the_whole_animation_for_any_count(text, frames, expected):
    assert frame_list(text, frames) == expected


@pytest.mark.parametrize("text", ["0:100", "30:", "-30:2"])
def test_a_slice_beyond_the_animation_is_refused(text):
    with pytest.raises(ValueError, match="frames 0 … 23 only"):
        frame_list(text, 24)


def test_temporal_ema_adds_its_seed_mode_with_less_noise_and_a_lag(cache, tmp_path):
    """``--temporal ema`` with the per-frame seed mode it filters: the summary has
    per-frame+ema beside it, each with its lag; the filtered caustic's own noise in the
    flicker is below the unfiltered one's (32² photon slots: noise-dominated). (With
    --fixed-seed alone it is refused: it once rendered every seed mode unasked.)"""
    out = tmp_path / "ema"
    assert main(["animate", "refocus", "-o", str(out), "--seed-per-frame", "--temporal", "ema", *ARGS]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["seed_modes"] == ["per-frame", "per-frame+ema"]
    plain, ema = s["metrics"]["per-frame"]["caustic"], s["metrics"]["per-frame+ema"]["caustic"]
    assert ema["flicker_approx_noise"] < plain["flicker_approx_noise"]
    assert all(np.isfinite(m["caustic"]["lag_frames"]) for m in s["metrics"].values())
