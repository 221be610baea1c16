"""`volcaustics measure` and ``experiment``: one experiment, its tables, and
the caustic's error decomposition explaining the whole error on every built-in."""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np
import pytest

from tests.shared import SINGLE_SCATTERING
from volcaustics.approx.params import QUICK, ApproxParams, ParamError
from volcaustics.experiment.image_rows import IMAGE_METRICS
from volcaustics.metrics.intersection import CLASS_NAMES
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.cli import main
from volcaustics.scenes.formats import COLOUR_LAYERS

SIZE = 64
# the reference's noise is 10–100× below E_∞,s's at this size (caustic floors 0–0.09%)
REFERENCE = ReferenceSettings(photons=1 << 20, spp=32, batches=8, width=SIZE, height=SIZE)
PARAMS = dataclasses.replace(QUICK, width=SIZE, height=SIZE)


def _strict_json(path):
    def no_constant(name):
        raise AssertionError(f"{path}: {name} is not JSON")

    return json.loads(path.read_text(), parse_constant=no_constant)


def test_measure_writes_tidy_tables_exr_and_summary(empty_cache, tmp_path, capsys, monkeypatch):
    """End to end at the report's measurement settings (16 exact sub-photons: the
    default), a single-scattering reference. Its references are its own (``empty_cache``):
    a test beside it that continued the shared entry between its two runs changed the
    point's key, and the second run measured again."""
    import OpenEXR
    import pandas as pd

    out = tmp_path / "m"
    args = ["measure", "refocus", "-o", str(out), "--seeds", "2", "--quiet", "--width", "32", "--height", "32",
            "--photon-res", "64", "--light-res", "64", "--layers", "2", "--photons", "65536", "--spp", "8",
            "--batches", "4", "--target-noise", "none", *SINGLE_SCATTERING]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "caustic error decomposed" in printed and "from the store" not in printed  # measured
    summary = _strict_json(out / "summary.json")
    from volcaustics.reports.measuring.runner import results_store
    stored = os.path.join(results_store().point_dir(summary["key"]), "summary.json")
    assert (out / "summary.json").read_bytes() == open(stored, "rb").read()  # one summary, the store's
    assert summary["exact"]["subphotons"] == 16  # the report's
    assert summary["params"]["layers"] == 2 and summary["seeds"] == 2 and summary["seed_values"] == [0, 1]
    assert summary["reference"]["key"] and summary["code_version"] and summary["versions"]["mitsuba"]
    reads = summary["map_reads"]  # the search's cost in texels: step 1 leaves the glass through the maps
    assert reads["per_frame"] > 0 and len(reads["per_step"]) == summary["params"]["steps"]
    assert reads["per_step"][0] > 0 and min(reads["per_step"]) >= 0
    assert min(reads["per_step"]) <= reads["per_segment"] <= max(reads["per_step"])

    for name in ("segments", "photons", "images"):
        table = pd.read_parquet(out / f"{name}.parquet")
        assert len(table) > 0
        assert len(pd.read_csv(out / f"{name}.csv")) == len(table)
        for column in ApproxParams.names() + ["scene", "scene_hash", "seeds", "reference_key", "code_version"]:
            assert column in table.columns, (name, column)
        assert (table["layers"] == 2).all() and (table["reference_key"] == summary["reference"]["key"]).all()

    segments = pd.read_parquet(out / "segments.parquet")
    everything = segments[segments["grouping"] == "all"].iloc[0]
    by_step = segments[segments["grouping"] == "step"]
    by_map = segments[segments["grouping"] == "step,map,inside"]
    assert by_step["segments"].sum() == everything["segments"] == by_map["segments"].sum()
    for name in CLASS_NAMES.values():
        assert by_map[f"count_{name}"].sum() == everything[f"count_{name}"]
    shares = everything[[f"share_{n}" for n in CLASS_NAMES.values()]].sum()
    assert shares == pytest.approx(1.0)
    assert str(segments["step"].dtype) == "Int64"

    photons = pd.read_parquet(out / "photons.parquet")
    for tracer in ("approx", "exact"):
        steps = photons[photons["tracer"] == tracer]["step"].tolist()
        assert steps == list(range(1, PARAMS.steps + 1))
    first = photons[(photons["tracer"] == "approx") & (photons["step"] == 1)].iloc[0]
    assert first["share_entering"] == pytest.approx(1.0)

    images = pd.read_parquet(out / "images.parquet")
    for component in COLOUR_LAYERS:
        metrics = set(images[(images["component"] == component) & images["term"].isna()]["metric"])
        assert metrics == set(IMAGE_METRICS)
    relmse = images[(images["component"] == "caustic") & (images["metric"] == "relative_mse")].iloc[0]
    assert np.isnan(relmse["ci_low"])  # two seeds: no interval (it needs MIN_SEEDS_FOR_INTERVAL)
    assert relmse["debiased"] == pytest.approx(relmse["value"] - relmse["reference_floor"] - relmse["approx_noise"])
    assert relmse["approx_noise"] > 0 and relmse["approx_noise_removed"]
    terms = images[(images["metric"] == "energy_share") & images["term"].notna()].set_index("term")
    parts = ["emission", "march", "intersection", "truncation", "reflections", "kernel_blur", "camera_volume",
             "residual"]
    assert terms.loc[parts, "value"].sum() == pytest.approx(terms.loc["total", "value"], abs=1e-9)
    assert (terms["standard_error"] >= 0).all()
    ratio = images[(images["component"] == "caustic") & (images["metric"] == "energy_ratio")].iloc[0]
    assert terms.loc["total", "value"] == pytest.approx(1 - ratio["value"], abs=1e-6)  # one convention for both

    with OpenEXR.File(str(out / "decomposition.exr")) as exr:
        channels = set(exr.channels())
    for layer in ("approx", "approx_exact_march", "reference", "exact_emission", "exact_all_small",
                  "exact_all_small_eye", "term.emission", "term.march", "term.intersection", "term.camera_volume",
                  "term.residual"):
        assert f"{layer}.R" in channels or layer in channels, (layer, sorted(channels)[:8])
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary files left

    # the same point again goes through the result store the report and the gate share:
    # read back, not measured, and written byte for byte as the first time
    again = tmp_path / "again"
    assert main([*args[:2], "-o", str(again), *args[4:]]) == 0
    assert "from the store" in capsys.readouterr().out
    for name in ("segments.parquet", "photons.csv", "images.parquet", "decomposition.exr"):
        assert (again / name).read_bytes() == (out / name).read_bytes(), name
    assert _strict_json(again / "summary.json")["key"] == summary["key"]

    # Ctrl-C while a second run writes its set (inside the EXR writer, after the tables):
    # the first run's eight files stay, byte for byte, and no temporaries
    import volcaustics.reports.presenting.exports.measure_files as write

    first = {p.name: p.read_bytes() for p in out.iterdir()}
    assert len(first) == 8

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(write, "write_exr", interrupted)
    assert main([*args, "--seed", "5"]) == 130
    assert {p.name: p.read_bytes() for p in out.iterdir()} == first


@pytest.mark.parametrize("args, message", [
    (["nosuch"], "built-in scene"),
    (["sphere1", "--seeds", "0"], "seeds = 0"),
    (["sphere1", "--layers", "0"], "layers = 0"),
    (["sphere1", "--seed", str(2**32 - 1), "--seeds", "2"], "2^32"),
])
def test_measure_bad_input_exits_2_and_writes_nothing(empty_cache, tmp_path, capsys, args, message):
    out = tmp_path / "never"
    assert main(["measure", *args, "-o", str(out), "--quiet"]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()
    assert not empty_cache.exists() or not any(empty_cache.rglob("*.exr"))  # nothing rendered


def test_measure_output_that_is_a_file_exits_2_before_rendering(empty_cache, tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("keep me")
    assert main(["measure", "sphere1", "-o", str(target), "--quiet"]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert target.read_text() == "keep me"
    assert not empty_cache.exists() or not any(empty_cache.rglob("*.exr"))


def test_start_normals_follow_the_photon_across_steps():
    """Step k's start normal is step k−1's hit normal of the same photon (records are
    not in photon order after compaction), nan at step 1 and where there was no hit."""
    from volcaustics.experiment.segments import start_normals as _start_normals
    from volcaustics.scenes.formats import RECORD_DTYPE

    step1 = np.zeros(3, RECORD_DTYPE)
    step1["photon"] = [7, 3, 5]
    step1["hit"] = [True, True, False]
    step1["normal"] = [[1, 0, 0], [0, 1, 0], [np.nan] * 3]
    step2 = np.zeros(3, RECORD_DTYPE)
    step2["photon"] = [3, 5, 7]
    normals = _start_normals([step1, step2])
    assert np.isnan(normals[0]).all()
    assert normals[1][0].tolist() == [0, 1, 0] and normals[1][2].tolist() == [1, 0, 0]
    assert np.isnan(normals[1][1]).all()


@pytest.mark.parametrize("value", ["0", "65"])
def test_the_sub_photons_out_of_range_exit_2_naming_the_flag_before_rendering(empty_cache, tmp_path, capsys, value):
    """--exact-subphotons (the suite mostly runs 1, the report 16) is checked before
    anything renders: exit 2 naming the flag, the value, the range and the default."""
    assert main(["measure", "refocus", "-o", str(tmp_path / "m"), "--seeds", "2", "--quiet", "--width", "32",
                 "--height", "32", "--photons", "65536", "--spp", "8", "--batches", "4", "--target-noise", "none",
                 *SINGLE_SCATTERING, "--exact-subphotons", value]) == 2
    err = capsys.readouterr().err
    assert f"--exact-subphotons = {value}: expected an integer in [1, 64]" in err and "default 16" in err, err
    assert "Traceback" not in err and not empty_cache.exists() and not (tmp_path / "m").exists()


def test_measure_passes_every_measurement_setting_on(cache, tmp_path):
    """`measure --subset-batches 4 --exact-steps 32` measures with them: the summary's
    decomposition has 4 batches per seed and E_∞ 32 steps (it once kept 8 and 128)."""
    out = tmp_path / "m"
    assert main(["measure", "refocus", "-o", str(out), "--seeds", "2", "--quiet", "--width", "32", "--height", "32",
                 "--photon-res", "64", "--light-res", "64", "--photons", "65536", "--spp", "8", "--batches", "4",
                 "--target-noise", "none", *SINGLE_SCATTERING, "--exact-subphotons", "1", "--subset-batches", "4",
                 "--exact-steps", "32"]) == 0
    exact = json.loads((out / "summary.json").read_text())["exact"]
    assert exact["subset_batches"] == 4 and exact["steps"] == 32, exact


def test_the_sub_photons_are_a_setting_of_the_result(cache, tmp_path):
    """The measurement setting exact_subphotons is recorded in the summary and part of a
    stored result's key: the runner measures a point once per setting."""
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.reports.measuring import runner
    from volcaustics.reports.measuring.results.store import Store

    keys = {}
    point = runner.Point("refocus", dataclasses.replace(PARAMS, width=32, height=32, photon_res=64, light_res=64),
                         seeds=2)
    for m in (1, 2):
        run = runner.measure([point], Store(str(tmp_path / "store")), reference_settings=REFERENCE,
                             measurement=MeasurementSettings(exact_subphotons=m), policy="missing", progress=False)
        keys[m] = run.keys[0]
        assert run.computed == 1 and run.results[0].summary["exact"]["subphotons"] == m
    assert keys[1] != keys[2]
    again = runner.measure([point], Store(str(tmp_path / "store")), reference_settings=REFERENCE,
                           measurement=MeasurementSettings(exact_subphotons=2), policy="missing", progress=False)
    assert again.keys == [keys[2]] and again.computed == 0 and again.done_before == 1


def test_subset_batches_and_exact_steps_are_settings_of_the_result(cache, tmp_path):
    """The other measurement settings reach the measurement: the decomposition's batches are
    subset_batches per seed, E_∞ replays exact_steps steps; each is in the result's key and
    its summary. Negative control: a value out of range is refused by name, before any work."""
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.reports.measuring import runner
    from volcaustics.reports.measuring.results.store import Store

    point = runner.Point("refocus", dataclasses.replace(PARAMS, width=32, height=32, photon_res=64, light_res=64),
                         seeds=2)
    settings = MeasurementSettings(exact_subphotons=1, subset_batches=4, exact_steps=64)
    run = runner.measure([point], Store(str(tmp_path / "store")), reference_settings=REFERENCE,
                         measurement=settings, policy="missing", progress=False)
    exact = run.results[0].summary["exact"]
    assert (exact["batches"], exact["subset_batches"], exact["steps"]) == (4 * 2, 4, 64)
    default = runner.measure([point], Store(str(tmp_path / "store")), reference_settings=REFERENCE,
                             measurement=MeasurementSettings(exact_subphotons=1), policy="missing", progress=False)
    assert default.keys != run.keys and default.results[0].summary["exact"]["batches"] == 8 * 2
    for name, value in (("subset_batches", 2), ("exact_steps", 16)):
        with pytest.raises(ParamError, match=f"{name} = {value}"):
            MeasurementSettings(**{name: value})


def test_a_reference_stopped_at_its_time_cap_above_its_target_is_said(empty_cache):
    """A reference whose time cap stops it above its noise target: summary.json names the
    component, its floor and target (its reference's ``short_of_target``) and warns; one that
    met its target (the negative control, another size so another cache entry) does not."""
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.experiment.pipeline import run_experiment
    from volcaustics.scenes import load_builtin

    scene = load_builtin("sphere1")
    summaries = {}
    for size, target in ((24, 1e-9), (20, 0.9)):
        settings = ReferenceSettings(photons=1 << 14, spp=4, batches=2, target_noise=target, max_seconds=1e-3,
                                     max_scatter=1, width=size, height=size)
        p = dataclasses.replace(PARAMS, width=size, height=size, photon_res=32, light_res=32)
        summaries[target] = run_experiment(scene, p, seeds=1, reference_settings=settings,
                                            measurement=MeasurementSettings(scope="gate")).summary
    capped, met = summaries[1e-9], summaries[0.9]
    assert capped["reference"]["stopped_by"] == "time cap"
    short = capped["reference"]["short_of_target"]
    assert set(short) == {"caustic", "fog", "direct"} and short["caustic"]["target"] == 1e-9
    assert short["caustic"]["noise_floor"] > 1e-9
    assert any("time cap above its noise target" in w and "caustic" in w for w in capped["warnings"])
    assert met["reference"]["stopped_by"] == "target" and met["reference"]["short_of_target"] == {}
    assert not any("noise target" in w for w in met["warnings"])


def test_the_measurement_settings_are_one_table_checked_once_when_made():
    """Every MeasurementSettings field carries its Param (the table the flags and the
    [measurement] keys come from); a value out of range or of the wrong type is refused
    when the settings are made, naming the setting and its default."""
    from volcaustics.experiment.measurement import (
        MEASUREMENT_KEYS,
        MEASUREMENT_PARAMS,
        MeasurementSettings,
    )

    fields = dataclasses.fields(MeasurementSettings)
    assert [f.metadata["param"] for f in fields] == list(MEASUREMENT_PARAMS)
    assert MEASUREMENT_KEYS == ("exact_subphotons", "subset_batches", "exact_steps")
    for changes, message in (({"exact_subphotons": 65}, "exact_subphotons = 65: expected an integer in [1, 64]"),
                             ({"exact_steps": 64.0}, "exact_steps = 64.0"), ({"scope": "all"}, "scope = 'all'")):
        with pytest.raises(ParamError, match="default") as exc:
            MeasurementSettings(**changes)
        assert message in str(exc.value)
    assert MeasurementSettings(exact_steps=64, scope="gate").to_dict()["exact_steps"] == 64  # the control


def test_the_reports_views_and_measures_layers_do_not_push_each_other_out(cache, tmp_path):
    """A point stored with the report's views and then asked for with measure's layers is
    measured once more, and kept with both: neither command measures it again after that
    (before: each removed the other's copy, so the report and measure took turns)."""
    from tests.shared import GATE_POINT, GATE_REFERENCE
    from volcaustics.experiment.measurement import MeasurementSettings
    from volcaustics.reports.measuring import runner
    from volcaustics.reports.measuring.results.store import Store

    store = Store(str(tmp_path / "store"))

    def run(images):
        return runner.measure([GATE_POINT], store, reference_settings=GATE_REFERENCE,
                              measurement=MeasurementSettings(exact_subphotons=1), policy="missing", images=images,
                              progress=False)

    assert run(("views",)).computed == 1
    key = run(()).keys[0]
    with pytest.MonkeyPatch.context() as mp:  # a measurement for the layers that fails keeps the stored point
        mp.setattr(runner, "run_experiment", lambda *a, **k: (_ for _ in ()).throw(RuntimeError("out of memory")))
        with pytest.raises(RuntimeError, match="out of memory"):
            run(("layers",))
    assert store.stored_images(key) == ("views",)
    twice = runner.measure([GATE_POINT, GATE_POINT], store, reference_settings=GATE_REFERENCE,  # one key, twice
                           measurement=MeasurementSettings(exact_subphotons=1), policy="missing", images=("layers",),
                           progress=False)
    assert twice.computed == 1  # the layers were not stored: measured again
    assert store.stored_images(key) == ("views", "layers")
    for images in (("views",), ("layers",), ("views", "layers")):
        done = run(images)
        assert done.computed == 0, images
        point = done.results[0]
        assert bool(point.views) == ("views" in images) and bool(point.layers) == ("layers" in images), images
