"""The public Python face: ``vc.measure`` returns a typed experiment with the numbers
``volcaustics measure`` writes for the same point, and ``import volcaustics`` loads no
renderer."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import pytest

from tests.shared import SINGLE_SCATTERING
from volcaustics.approx.params import QUICK
from volcaustics.experiment.result import Experiment
from volcaustics.experiment.sizing import REPORT_REFERENCE
from volcaustics.infra.errors import InputError
from volcaustics.reports.cli import main

SMALL = {"width": 32, "height": 32, "photon_res": 64, "light_res": 64, "layers": 2}
REFERENCE = dataclasses.replace(REPORT_REFERENCE, photons=65536, spp=8, batches=4, target_noise=None, max_scatter=1)


def test_measure_returns_the_typed_experiment_the_command_writes(empty_cache, tmp_path, capsys, monkeypatch):
    # its own references: a shared entry continued by another test between the two calls changes the key
    import volcaustics as vc
    from volcaustics.scenes import loader

    parsed = []
    parse = loader.parse_scene
    monkeypatch.setattr(loader, "parse_scene", lambda *a, **k: parsed.append(1) or parse(*a, **k))
    e = vc.measure("refocus", seeds=2, reference=REFERENCE, **SMALL)
    assert len(parsed) == 1  # the scene is resolved once, and travels with the point (before: 4 times)
    assert isinstance(e, Experiment) and e.scene == "refocus" and e.seeds == 2 and e.params.photon_res == 64
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.seeds = 3  # type: ignore[misc]
    assert e.equal_cost is None  # quick is not matched to the paper's cost
    assert {"intersection", "truncation", "kernel_blur", "residual"} <= {r.term for r in e.decomposition}
    assert len(e.images_table()) == len(e.images) and len(e.decomposition_table()) == len(e.decomposition)
    assert len(e.tables["segments"]) > 0
    assert e.map_reads is not None and e.map_reads.per_frame > 0 and e.seconds > 0
    assert e.model is None  # a single-scattering reference (max_scatter 1): no model term

    # the same point through the command: read back from the store, the same numbers
    out = tmp_path / "m"
    args = ["measure", "refocus", "-o", str(out), "--seeds", "2", "--quiet", "--width", "32", "--height", "32",
            "--photon-res", "64", "--light-res", "64", "--layers", "2", "--photons", "65536", "--spp", "8",
            "--batches", "4", "--target-noise", "none", *SINGLE_SCATTERING]
    assert main(args) == 0
    assert "from the store" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    written = Experiment.from_summary(summary)
    assert written.key == e.key
    for metric in ("relative_mse", "frame_relative_mse", "energy_ratio"):
        assert written.metric(metric) == e.metric(metric)
    assert written.decomposition == e.decomposition
    assert e.metric().debiased == summary["images"]["caustic"]["relative_mse"]["debiased"]
    # what the report copies into its own summary.json comes back from the types as stored
    for component, metrics in summary["images"].items():
        for metric, stored in metrics.items():
            assert written.metric(metric, component).to_json() == stored, (component, metric)
    assert [r.to_json() for r in written.decomposition] == summary["decomposition"]["rows"]
    assert written.closure is not None and written.closure.to_json() == summary["decomposition"]["residual"]
    assert written.map_reads is not None and written.map_reads.to_json() == summary["map_reads"]
    assert written.reference is not None and written.reference.to_json() == summary["reference"]


def test_a_summary_of_another_schema_is_refused_naming_it():
    summary = {"schema": 99, "scene": "sphere1"}
    with pytest.raises(InputError, match="schema = 99"):
        Experiment.from_summary(summary)  # type: ignore[arg-type]


def test_a_metric_not_measured_is_a_key_error_naming_those_there_are():
    e = Experiment(scene="s", scene_hash="h", key="k", params=QUICK, seeds=1, images=(), decomposition=(),
                   cost=None, equal_cost=None, warnings=(), code_version="c")  # type: ignore[arg-type]
    with pytest.raises(KeyError, match="no caustic relative_mse"):
        e.metric()


def test_a_bad_parameter_is_refused_before_anything_renders(cache):
    import volcaustics as vc

    with pytest.raises(InputError, match="photon_res"):
        vc.measure("refocus", photon_res=-1)
    with pytest.raises(InputError, match="preset"):
        vc.measure("refocus", preset="fastest")
    with pytest.raises(InputError, match="photon_ress.*photon_res"):  # a misspelt name: the table's names, no TypeError
        vc.measure("refocus", photon_ress=64)


def test_importing_volcaustics_loads_no_renderer():
    # vc.measure is resolved on first use: importing the package alone loads nothing heavy
    done = subprocess.run([sys.executable, "-c", "import sys, volcaustics; print(sorted(m for m in "
                           "('moderngl', 'mitsuba', 'drjit', 'pandas') if m in sys.modules))"],
                          capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]", done.stdout
    with pytest.raises(AttributeError, match="no attribute 'mesure'"):
        import volcaustics

        volcaustics.mesure  # noqa: B018


def test_render_approx_is_the_renderer_s_frame_on_the_named_scene():
    """vc.render_approx resolves the name and the preset as `volcaustics approx` does: the
    frame equals the renderer's own on the loaded scene; another seed's frame does not."""
    import numpy as np

    import volcaustics as vc
    from volcaustics.approx.params import preset
    from volcaustics.approx.renderer import render
    from volcaustics.scenes import load_builtin

    small = {**SMALL, "photon_res": 32, "light_res": 32}
    frame = vc.render_approx("refocus", **small)
    same = render(load_builtin("refocus"), preset("paper", **small))
    other = vc.render_approx("refocus", seed=1, **small)  # negative control: the comparison can fail
    assert frame.images["caustic"].shape == (32, 32, 3) and frame.params == same.params
    assert np.array_equal(frame.images["caustic"], same.images["caustic"])
    assert not np.array_equal(frame.images["caustic"], other.images["caustic"])


def test_render_reference_renders_once_then_reads_the_cache(empty_cache):
    import volcaustics as vc

    small = dataclasses.replace(REFERENCE, width=32, height=32)
    first = vc.render_reference("refocus", small)
    again = vc.render_reference("refocus", small)
    assert first.mean["caustic"].shape == (32, 32, 3) and not first.cached and again.cached
    assert (again.mean["caustic"] == first.mean["caustic"]).all() and first.key == again.key


@pytest.mark.slow  # two points measured end to end, then resumed: about 10 s on 2 cores
def test_sweep_from_python_measures_the_grid_and_resumes(cache, tmp_path):
    import volcaustics as vc

    grid = {"scenes": ["refocus"], "vary": {"layers": [1, 2]}, "fixed": {"width": 32, "height": 32, "photon_res": 64,
                                                                          "light_res": 64},
            "reference": {"photons": 65536, "spp": 8, "batches": 4, "target_noise": "none", "max_scatter": 1},
            "measurement": {"exact_subphotons": 1}}
    result = vc.sweep(str(tmp_path / "s"), **grid)
    assert result.computed == 2 and not result.failed
    assert sorted(result.tables["points"]["layers"]) == [1, 2]
    again = vc.sweep(str(tmp_path / "s"), **grid)
    assert again.computed == 0 and again.done_before == 2
    with pytest.raises(InputError, match="photons"):  # a bad budget: refused before anything renders
        vc.sweep(str(tmp_path / "t"), **{**grid, "reference": {"photons": -1}})


def test_frames_refuses_a_seed_count_without_a_frame_error(tmp_path):
    import volcaustics as vc

    with pytest.raises(InputError, match="seeds = 1"):
        vc.frames(str(tmp_path / "f"), scenes=["refocus"], seeds=1)
    assert not (tmp_path / "f").exists()



@pytest.mark.slow  # the check renders the paper's frames at its own photon and light resolution: 20-40 s
def test_a_matched_presets_equal_cost_is_measured_once_and_kept_with_the_point(empty_cache):
    """The equal-cost check (a measured time: it differs run to run) is stored in the
    point's summary: the second call reads it back, equal to the float; the store keeps
    its own fields to itself, and a point not there cannot be amended (negative controls)."""
    import volcaustics as vc
    from volcaustics.reports.measuring.runner import results_store

    small = {"width": 32, "height": 32, "light_res": 64, "photon_res": 64, "layers": 1}  # no match: the check alone
    first = vc.measure("refocus", preset="beams", seeds=2, reference=REFERENCE, **small)
    assert first.equal_cost is not None and first.equal_cost.measured_ratio > 0
    again = vc.measure("refocus", preset="beams", seeds=2, reference=REFERENCE, **small)
    assert again.equal_cost == first.equal_cost and again.key == first.key
    store = results_store()
    assert store.summary(first.key)["equal_cost"]["measured_time"]["ratio"] == first.equal_cost.measured_ratio
    with pytest.raises(ValueError, match="files belong to the store"):
        store.amend_summary(first.key, {"files": {}})
    with pytest.raises(OSError, match="not complete"):
        store.amend_summary("0" * 32, {"equal_cost": None})


@pytest.mark.parametrize("call, match", [
    (lambda vc, t: vc.measure(None), "scene = None"),
    (lambda vc, t: vc.render_approx(3), "scene = 3"),
    (lambda vc, t: vc.measure("refocus", preset=["quick"]), "preset"),
    (lambda vc, t: vc.measure("refocus", name="x"), "name"),  # a parameter named like the preset's own argument
    (lambda vc, t: vc.measure("refocus", reference={"photon": 5}), "reference"),
    (lambda vc, t: vc.measure("refocus", reference={"width": 48}), "reference.width"),  # the frame sets the size
    (lambda vc, t: vc.measure("refocus", measurement={"exact_subphotonz": 1}), "exact_subphotonz"),
    (lambda vc, t: vc.measure("refocus", reference="big"), "reference = 'big'"),
    (lambda vc, t: vc.sweep(str(t / "s"), scenes=["refocus"], vary={"layers": []}), "non-empty list"),
    (lambda vc, t: vc.sweep(str(t / "s"), scenes=["refocus"], vary={"layers": 2}), "non-empty list"),
    (lambda vc, t: vc.sweep(str(t / "s"), scenes=["refocus"], vary={"photonres": [32, 64]}), "photonres"),
    (lambda vc, t: vc.sweep(str(t / "s"), scenes=[]), "scenes"),
    (lambda vc, t: vc.sweep(str(t / "s"), scenes="refocus"), "expected a list"),
    (lambda vc, t: vc.sweep(str(t / "s"), spec=str(t / "x.toml"), seeds=2), "belong to the spec file"),
    (lambda vc, t: vc.sweep(str(t / "s"), scenes=["refocus"], workers=0), "workers = 0"),
    (lambda vc, t: vc.sweep(str(t / "s"), scenes=["refocus"], dask="nonsense://x"), "dask"),
    (lambda vc, t: vc.sweep(str(t / "afile"), scenes=["refocus"]), "not a folder"),
    (lambda vc, t: vc.frames(str(t / "afile"), scenes=["refocus"], seeds=2), "not a folder"),
    (lambda vc, t: vc.frames(str(t / "afile" / "under"), scenes=["refocus"], seeds=2), "cannot write there"),
    (lambda vc, t: vc.frames(str(t / "f"), scenes=[], seeds=2), "at least one scene"),
    (lambda vc, t: vc.frames(None, scenes=["refocus"], seeds=2), "output = None"),
])
def test_a_bad_argument_from_python_is_an_input_error_naming_it_before_any_work(call, match, tmp_path, empty_cache):
    """What a notebook user gets wrong (a hostile pass found each) is refused in one line
    naming the argument, before anything renders: no TypeError, KeyError or OSError from
    deep inside, and no silently ignored argument."""
    import volcaustics as vc

    (tmp_path / "afile").write_text("")
    with pytest.raises(InputError, match=match):
        call(vc, tmp_path)
    assert not (empty_cache / "reference").exists()  # nothing rendered


def test_a_path_object_names_a_scene_and_dir_lists_the_public_functions(tmp_path):
    import pathlib

    import volcaustics as vc
    from volcaustics.scenes import resolve_scene
    from volcaustics.scenes.catalogue import builtin_path

    assert resolve_scene(pathlib.Path(builtin_path("refocus"))).scene_hash() == resolve_scene("refocus").scene_hash()
    assert {"measure", "render_approx", "render_reference", "sweep", "frames"} <= set(dir(vc))


def test_a_summary_that_is_not_an_experiments_is_refused_naming_what_it_lacks():
    from volcaustics.experiment.summaries import SCHEMAS

    with pytest.raises(InputError, match="no images"):
        Experiment.from_summary({"schema": SCHEMAS["experiment"], "scene": "s"})  # type: ignore[typeddict-item]
    with pytest.raises(InputError, match="expected an experiment's summary"):
        Experiment.from_summary("x")  # type: ignore[arg-type]


def test_two_names_of_one_scene_are_two_points_each_labelled_its_own():
    """The store keyed points by content alone, so a copy of sphere1 named "mine" read back
    as "sphere1" (or the reverse, by which came first): the name is in the key now."""
    from volcaustics.reference.cache import ReferenceResult
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.reports.measuring.results.store import key_document, point_key
    from volcaustics.scenes import load_builtin

    scene = load_builtin("sphere1")
    mine = dataclasses.replace(scene, name="mine")
    assert mine.scene_hash() == scene.scene_hash()  # one content
    reference = ReferenceResult("k" * 32, {"files": {"exr": "k" * 32 + ".r.exr", "png": "k" * 32 + ".r.png"}},
                                True, {})
    keys = {point_key(key_document(s, QUICK, 2, reference, ReferenceSettings())) for s in (scene, mine)}
    assert len(keys) == 2


def test_the_model_term_reads_into_its_types_a_component_without_numbers_keeps_its_note():
    from volcaustics.experiment.result import ModelTerm

    estimate = {"value": 0.1, "debiased": 0.09, "standard_error": 0.01}
    caustic = {name: estimate for name in ("energy_share", "relmse_own", "relmse_part")}
    term = ModelTerm.from_json({"max_scatter": 8, "orders_needed": {"caustic": 3, "fog": None}, "converged": False,
                                "components": {"caustic": caustic, "fog": {"note": "black reference"}}})
    caustic, fog = term.components
    assert term.max_scatter == 8 and term.orders_needed["fog"] is None and not term.converged
    assert caustic.relmse_own.debiased == 0.09 and fog.energy_share is None and fog.note == "black reference"
    assert ModelTerm.from_json(None) is None
