"""`volcaustics compare`: another renderer's EXRs measured as the approximation is —
``measure``'s numbers to the bit on the approximation's own files, analytic values on
a scaled reference (the negative control), exit 2 naming the problem for every image
it cannot judge, and the gate holding a renderer to its budgets."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pandas as pd
import pytest

from tests.shared import FAST_MEASUREMENT, SINGLE_SCATTERING, SMALL_REFERENCE_TABLES, with_shared_references
from volcaustics.infra.imageio import read_exr, write_exr, write_png
from volcaustics.reports.cli import main
from volcaustics.reports.studies.compare.comparison_inputs import CompareError, read_images
from volcaustics.scenes import load_builtin
from volcaustics.scenes.formats import COLOUR_LAYERS, MASK_LAYER

SIZE = ["--width", "32", "--height", "32", "--photon-res", "64", "--light-res", "64", "--layers", "2",
        "--preset", "quick"]
REFERENCE = ["--photons", "65536", "--spp", "8", "--batches", "4", "--target-noise", "none", *SINGLE_SCATTERING]
NUMBERS = ["value", "reference_floor", "approx_noise", "debiased", "standard_error", "ci_low", "ci_high",
           "reference_sigma", "approx_noise_removed"]


@pytest.fixture(scope="module")
def shots(tmp_path_factory, shared_references):
    """The approximation's frames of refocus at 32² (seeds 0, 1) as `approx` writes them,
    and `measure` with the same parameters, seeds and reference."""
    root = tmp_path_factory.mktemp("compare")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VOLCAUSTICS_CACHE", str(with_shared_references(root / "cache", shared_references)))
        for seed in (0, 1):
            assert main(["approx", "refocus", "-o", str(root / f"s{seed}.exr"), *SIZE, "--seed", str(seed),
                         "--records-max", "0"]) == 0
        assert main(["measure", "refocus", "-o", str(root / "measure"), "--seeds", "2", "--quiet", *SIZE,
                     *REFERENCE, *FAST_MEASUREMENT]) == 0
        yield root


@pytest.fixture
def env(shots, monkeypatch):
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(shots / "cache"))
    return shots


def compare(env, *images, out="cmp", name=None):
    args = ["compare", "refocus", *map(str, images), "-o", str(env / out), "--quiet", *REFERENCE]
    return main(args + (["--name", name] if name else []))


def _image_numbers(path) -> pd.DataFrame:
    table = pd.read_parquet(path)
    if "term" in table:
        table = table[table["term"].isna()]
    return table.set_index(["component", "metric"])[NUMBERS].sort_index()


def test_compare_reproduces_measure_on_the_approximations_own_files(env, capsys):
    """The same frames through files: every image metric, floor, noise and interval equal
    to `measure`'s (one code path: experiment.image_rows)."""
    assert compare(env, env / "s0.exr", env / "s1.exr", name="approx-files") == 0
    assert "relative MSE debiased" in capsys.readouterr().out
    ours, theirs = _image_numbers(env / "cmp" / "images.parquet"), _image_numbers(env / "measure" / "images.parquet")
    pd.testing.assert_frame_equal(ours, theirs, check_exact=True)
    summary = json.loads((env / "cmp" / "summary.json").read_text())
    measured = json.loads((env / "measure" / "summary.json").read_text())
    assert summary["reference"]["key"] == measured["reference"]["key"]
    assert summary["compared_pixels"] == measured["compared_pixels"] and summary["mask"] == "file"
    assert summary["renderer"] == "approx-files" and summary["components"] == list(COLOUR_LAYERS)
    assert [f["sha256"] for f in summary["inputs"]] and summary["inputs"][0]["layers"][-1] == MASK_LAYER
    views, _ = read_exr(str(env / "cmp" / "views.exr"))
    for component in COLOUR_LAYERS:
        assert {f"renderer.{component}", f"reference.{component}"} <= set(views)
    assert "map.hdr_flip.caustic" in views and "compared" in views
    page = (env / "cmp" / "index.html").read_text()
    assert "approx-files against ground truth" in page and "compare-row" in page and "src='data:image/png" in page
    assert not [p for p in (env / "cmp").iterdir() if p.name.startswith(".")]  # no temporaries left


def test_a_scaled_reference_gives_the_analytic_error(env, tmp_path):
    """Negative control: the reference's own mean scores relative MSE 0 and energy ratio 1;
    the same × 1.2 must score (1.2 − 1)² = 0.04 and 1.2, flagged in every component."""
    from volcaustics.reference.cache import existing_reference
    from volcaustics.reference.settings import ReferenceSettings
    settings = ReferenceSettings(photons=65536, spp=8, batches=4, target_noise=None, width=32, height=32,
                                 max_scatter=1)  # REFERENCE's
    reference = existing_reference(load_builtin("refocus"), settings)
    assert reference is not None  # the module fixture rendered it
    exact = {c: reference.mean[c] for c in COLOUR_LAYERS}
    exact[MASK_LAYER] = reference.mean[MASK_LAYER]
    write_exr(str(tmp_path / "exact.exr"), exact)
    write_exr(str(tmp_path / "bright.exr"), {**{c: 1.2 * reference.mean[c] for c in COLOUR_LAYERS},
                                             MASK_LAYER: reference.mean[MASK_LAYER]})
    assert compare(env, tmp_path / "exact.exr", out="exact") == 0
    assert compare(env, tmp_path / "bright.exr", out="bright") == 0
    exact_rows, bright_rows = (_image_numbers(env / name / "images.parquet") for name in ("exact", "bright"))
    for component in COLOUR_LAYERS:
        # float32 files: the ratios hold to float32 rounding
        assert exact_rows.loc[(component, "relative_mse"), "value"] == pytest.approx(0.0, abs=1e-12)
        assert exact_rows.loc[(component, "energy_ratio"), "value"] == pytest.approx(1.0, rel=1e-6)
        assert bright_rows.loc[(component, "relative_mse"), "value"] == pytest.approx(0.04, rel=1e-5)
        assert bright_rows.loc[(component, "energy_ratio"), "value"] == pytest.approx(1.2, rel=1e-5)
        # the debiased error subtracts the reference's floor (one file: no own noise to remove)
        row = bright_rows.loc[(component, "relative_mse")]
        assert row["debiased"] == pytest.approx(0.04 - row["reference_floor"], rel=1e-6)
        assert not row["approx_noise_removed"]


def test_root_rgb_is_compared_as_combined(env, tmp_path):
    """A beauty-only file (root R, G, B) with the approximation's mask: its combined row is
    the layered file's, and nothing else is compared."""
    layers, _ = read_exr(str(env / "s0.exr"))
    import OpenEXR

    channels = {c: np.ascontiguousarray(layers["combined"][..., k]) for k, c in enumerate("RGB")}
    channels[f"{MASK_LAYER}.Y"] = np.ascontiguousarray(layers[MASK_LAYER][..., 0])
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, channels) as f:
        f.write(str(tmp_path / "beauty.exr"))
    assert compare(env, tmp_path / "beauty.exr", out="beauty") == 0
    assert compare(env, env / "s0.exr", out="layered") == 0
    beauty, layered = (_image_numbers(env / name / "images.parquet") for name in ("beauty", "layered"))
    assert set(beauty.index.get_level_values("component")) == {"combined"}
    pd.testing.assert_frame_equal(beauty, layered.loc[["combined"]], check_exact=True)
    summary = json.loads((env / "beauty" / "summary.json").read_text())
    assert summary["components"] == ["combined"]


def _damaged(env, tmp_path, case):
    """A file that `compare` must refuse, and the words its message must hold."""
    layers, _ = read_exr(str(env / "s0.exr"))
    path = tmp_path / f"{case}.exr"
    if case == "aspect":
        write_exr(str(path), {c: layers[c][:, :16] for c in layers})
        return [path], "aspect ratio"
    if case == "sizes":
        write_exr(str(path), {c: layers[c][:16, :16] for c in layers})
        return [env / "s0.exr", path], "same size"
    if case == "missing_layer":
        write_exr(str(path), {c: layers[c] for c in ("caustic", "fog")})
        return [path], "no direct"
    if case in ("nan", "inf"):
        bad = layers["fog"].copy()
        bad[3, 5, 1] = np.nan if case == "nan" else np.inf
        write_exr(str(path), {**layers, "fog": bad})
        return [path], "row 3, column 5"
    if case == "negative":
        bad = layers["caustic"].copy()
        bad[7, 2, 0] = -0.5
        write_exr(str(path), {**layers, "caustic": bad})
        return [path], "negative"
    if case == "png":
        path = tmp_path / "shot.exr"  # a PNG under an EXR's name
        write_png(str(path), layers["combined"])
        return [path], "is a PNG"
    if case == "not_exr":
        path.write_text("P3 1 1 255 0 0 0\n")
        return [path], "not an OpenEXR file"
    if case == "truncated":
        path.write_bytes((env / "s0.exr").read_bytes()[:300])
        return [path], "unreadable OpenEXR"
    if case == "missing_file":
        return [tmp_path / "nowhere.exr"], "no such file"
    if case == "folder":
        return [tmp_path], "is a folder"
    if case == "twice":
        return [env / "s0.exr", env / "s0.exr"], "given twice"
    # one file under two names
    if case == "spelled_twice":
        return [env / "s0.exr", f"{env}/./s0.exr"], f"the same file as {env / 's0.exr'}"
    if case == "symlink":
        path.symlink_to(env / "s0.exr")
        return [env / "s0.exr", path], "the same file as"
    if case == "hard_link":
        os.link(env / "s0.exr", path)
        return [env / "s0.exr", path], "the same file as"
    if case == "copy":
        shutil.copyfile(env / "s0.exr", path)
        return [env / "s0.exr", path], f"the same bytes as {env / 's0.exr'}"
    if case == "mask_range":
        bad = layers[MASK_LAYER].copy()
        bad[1, 2] = -1.0
        write_exr(str(path), {**layers, MASK_LAYER: bad})
        return [path], "outside [0, 1]"
    if case == "other_scene":
        assert main(["approx", "sphere1", "-o", str(path), *SIZE, "--records-max", "0"]) == 0
        return [path], "not 'refocus'"
    raise AssertionError(case)


BAD = ("aspect", "sizes", "missing_layer", "nan", "inf", "negative", "png", "not_exr", "truncated", "missing_file",
       "folder", "twice", "other_scene", "spelled_twice", "symlink", "hard_link", "copy", "mask_range")


@pytest.mark.parametrize("case", BAD)
def test_an_image_that_cannot_be_judged_exits_2_naming_it(env, tmp_path, capsys, monkeypatch, case):
    images, words = _damaged(env, tmp_path, case)
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path / "empty-cache"))  # nothing renders before the checks
    capsys.readouterr()
    assert main(["compare", "refocus", *map(str, images), "-o", str(tmp_path / "out"), "--quiet", *REFERENCE]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err, err
    assert not (tmp_path / "empty-cache" / "reference").exists() and not (tmp_path / "out").exists()


def test_images_beyond_memory_are_refused_before_their_pixels_load(env, tmp_path, capsys, monkeypatch):
    """A 4096² EXR grew compare to 11.7 GB while it rendered the reference:
    the size is checked from the files' headers against the memory compare needs, with
    measure's one check. Here the machine's budget is made small instead of the file
    large: 32² pixels × 2 files need 1,800 × 1,024 bytes."""
    import volcaustics.infra.memory as memory

    monkeypatch.setattr(memory, "memory_budget", lambda: 1 << 20)
    monkeypatch.setattr("volcaustics.reports.studies.compare.comparison_inputs._channels",
                        lambda *_: pytest.fail("pixels read"))
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path / "empty-cache"))
    capsys.readouterr()
    assert main(["compare", "refocus", str(env / "s0.exr"), str(env / "s1.exr"), "-o", str(tmp_path / "out"),
                 "--quiet", *REFERENCE]) == 2
    err = capsys.readouterr().err
    assert "more than half of this machine's memory" in err and "or fewer seeds" in err, err
    assert not (tmp_path / "empty-cache" / "reference").exists()


def test_the_checks_name_the_file_without_rendering(env):
    """The library's check, without the CLI: the message names the file."""
    with pytest.raises(CompareError, match="nowhere.exr: no such file"):
        read_images(["nowhere.exr"], load_builtin("refocus"))


BUDGETS = """preset = "quick"
seeds = 2
""" + SMALL_REFERENCE_TABLES + """[scene.refocus]
caustic = {{ energy_ratio = [0.0, 10.0] }}
[compare.files.refocus]
caustic = {{ relmse_max = {caustic}, energy_ratio = [0.5, 1.0] }}
combined = {{ energy_ratio = [0.5, 1.5] }}
"""
GATE = ["--set", "width=32", "--set", "height=32", "--set", "photon_res=64", "--set", "light_res=64", "--set",
        "layers=2", "--quiet", "--render-references"]


def test_the_gate_holds_another_renderer_to_its_budgets(env, tmp_path, capsys):
    """Pass within the limits, exit 1 beyond one (named compare.files.…), exit 2 for a
    renderer without budgets or a comparison edited after it was written."""
    assert compare(env, env / "s0.exr", env / "s1.exr", out="gated", name="files") == 0
    caustic = json.loads((env / "gated" / "summary.json").read_text())["images"]["caustic"]["relative_mse"]
    # 3× the measured error passes; a tenth of it fails (the floor at this size is far below either)
    loose, tight = (tmp_path / "loose.toml", tmp_path / "tight.toml")
    loose.write_text(BUDGETS.format(caustic=3 * caustic["debiased"]))
    tight.write_text(BUDGETS.format(caustic=caustic["debiased"] / 10))
    gate = ["gate", "--out", str(tmp_path / "g"), *GATE]
    assert main([*gate, "--budgets", str(loose), "--compare", f"files={env / 'gated'}"]) == 0
    out = capsys.readouterr().out
    assert "compare.files.caustic.relmse_max" in out and "compare.files.combined.energy_ratio" in out
    assert main([*gate, "--budgets", str(tight), "--compare", f"files={env / 'gated'}"]) == 1
    assert "FAIL" in capsys.readouterr().out
    verdict = json.loads((tmp_path / "g" / "gate.json").read_text())
    failed = [c["name"] for c in verdict["checks"] if not c["passed"]]
    assert failed == ["compare.files.caustic.relmse_max"]
    assert main([*gate, "--budgets", str(loose), "--compare", f"other={env / 'gated'}"]) == 2
    assert "no [compare.other.refocus] budgets" in capsys.readouterr().err
    edited = tmp_path / "edited"
    shutil.copytree(env / "gated", edited)
    doc = json.loads((edited / "summary.json").read_text())
    doc["images"]["caustic"]["relative_mse"]["debiased"] = 0.0
    (edited / "summary.json").write_text(json.dumps(doc))
    assert main([*gate, "--budgets", str(loose), "--compare", f"files={edited}"]) == 2
    assert "SHA-256" in capsys.readouterr().err
    assert main([*gate, "--budgets", str(loose), "--compare", "files"]) == 2
    assert "expected NAME=DIR" in capsys.readouterr().err


def test_nan_in_a_channel_not_compared_is_named_in_the_warnings(env, tmp_path):
    """It passed without a word; the compared layers stay as they are."""
    layers, _ = read_exr(str(env / "s0.exr"))
    extra = np.zeros_like(layers["caustic"])
    extra[0, 0, 2] = np.nan
    path = tmp_path / "extra.exr"
    write_exr(str(path), {**layers, "albedo": extra})
    inputs = read_images([str(path)], load_builtin("refocus"))
    assert any("albedo.B" in w and "not compared" in w for w in inputs.warnings), inputs.warnings
    clean = read_images([str(env / "s0.exr")], load_builtin("refocus"))
    assert not any("NaN" in w for w in clean.warnings)


@pytest.mark.parametrize("field", ["scene", "scene_hash", "images"])
def test_a_resealed_summary_missing_what_is_read_is_refused(env, tmp_path, field):
    """A summary without what the report and the gate read, sealed again so its SHA-256
    matches, once passed the reader and failed later with a KeyError; now it is refused at
    load naming the field. The intact folder loads (the negative control)."""
    from volcaustics.infra.errors import InputError
    from volcaustics.infra.storage import document_sha256
    from volcaustics.reports.studies.compare.comparison_read import load_comparison
    from volcaustics.reports.studies.compare.comparison_write import SEAL

    assert compare(env, env / "s0.exr", env / "s1.exr", out="cmp_read") == 0
    folder = tmp_path / "cmp"
    shutil.copytree(env / "cmp_read", folder)
    assert load_comparison(str(folder), views=False).scene == "refocus"
    path = folder / "summary.json"
    doc = json.loads(path.read_text())
    doc[field] = {} if field == "images" else None
    doc[SEAL] = document_sha256(doc, SEAL)
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=f"{field} = "):
        load_comparison(str(folder), views=False)
