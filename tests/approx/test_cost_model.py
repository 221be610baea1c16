"""The cost model's weight sets (``approx.cost_model``): the shipped ones load, say where
they come from and what their fit achieved; the GPU set reproduces the paper's pass
shares at its anchor; a damaged weight file is refused naming the file, the key and the
value; a frame's predicted time grows with its splat fragments."""

from __future__ import annotations

import dataclasses
import json
import math
import os

import pytest

from volcaustics.approx.cost_model import (
    MAX_WEIGHT,
    MIN_WEIGHT,
    MODEL_PASSES,
    WEIGHTS_DIR,
    WeightSet,
    WeightSetError,
    always_counted,
    features,
    read_weight_set,
    weight_sets,
)
from volcaustics.approx.params import PAPER, param
from volcaustics.infra.errors import InputError

HELD_OUT_GOAL = 0.15  # the cost model's goal on what its fit left out: the median point's frame time error
HELD_OUT_WORST = 0.25  # measured worst: llvmpipe 23% (dense_forward), H200 24.6% (docs/decisions.md "Frame cost")


def test_the_shipped_weight_sets_load_with_their_provenance():
    sets = weight_sets()
    assert {"llvmpipe", "paper_gpu"} <= set(sets)
    fitted = [ws for name, ws in sets.items() if name == "llvmpipe" or name.startswith("gpu_")]
    assert len(fitted) >= 1
    for ws in fitted:  # a machine's fit: its GL renderer, machine, date and its error where it was not fitted
        assert set(ws.weights) <= set(MODEL_PASSES) and ws.unit == "s"
        p = ws.provenance
        assert ws.name.removeprefix("gpu_")[:6] in p["gl_renderer"].lower().replace(" ", "_").replace("/", "_")
        assert p["date"] and p["machine"]
        held = p["held_out"]
        for group in ("configs_on_builtins", "scenes_every_config"):
            assert held[group]["median_abs_error"] <= HELD_OUT_GOAL and held[group]["max_abs_error"] <= HELD_OUT_WORST
        assert {"knot", "lens_array", "dense_forward"} <= set(held["scenes"])


def test_the_gpu_set_gives_the_papers_pass_shares_at_its_anchor():
    """At the paper's configuration (the counts it was anchored on) trace is 70% and
    splatting 23% of the frame, which is 1 unit; the llvmpipe set, the negative control,
    splits the same frame otherwise."""
    sets = weight_sets()
    gpu = sets["paper_gpu"]
    counts = gpu.provenance["paper_counts"]
    params = PAPER.resolved(_scene(gpu.provenance["scene"]))
    t = gpu.predict(counts, params)
    assert t["frame"] == pytest.approx(1.0, rel=1e-9)
    assert t["trace"] == pytest.approx(0.70, rel=1e-9)
    assert t["splat"] + t["density"] == pytest.approx(0.23, rel=1e-9)
    cpu = sets["llvmpipe"].predict(counts, params)
    assert abs(cpu["trace"] / cpu["frame"] - 0.70) > 0.05


def _scene(name):
    from volcaustics.scenes import resolve_scene

    return resolve_scene(name)


def test_more_splat_fragments_cost_more_time():
    fitted = weight_sets()["llvmpipe"]
    params = PAPER.resolved(_scene("sphere1"))
    counts = dict(weight_sets()["paper_gpu"].provenance["paper_counts"])
    before = fitted.frame(counts, params)
    counts["fragments_splat"] *= 4
    assert fitted.frame(counts, params) > before
    assert features(counts, params)["splat"]["fragments"] == counts["fragments_splat"]


@pytest.mark.parametrize("doc, says", [
    ("not json", "cannot be read as JSON"),
    ({"weights": {"splat": {"fragments": -1.0}}}, "weights.splat.fragments = -1.0"),
    ({"weights": {"splat": {"texels": 1.0}}}, "weights.splat.texels: unknown feature"),
    ({"weights": {"raytrace": {"calls": 1.0}}}, "weights.raytrace"),
    ({"weights": {"fog": {"calls": True}}}, "weights.fog.calls = True"),
    ({"unit": "s"}, "expected an object with 'weights'"),
])
def test_a_damaged_weight_file_is_refused_naming_file_key_and_value(tmp_path, doc, says):
    path = tmp_path / "bad.json"
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    with pytest.raises(WeightSetError) as exc:
        read_weight_set(str(path))
    assert str(path) in str(exc.value) and says in str(exc.value)


def test_a_set_prices_only_the_splat_modes_its_fit_measured():
    """A beam's fragment runs its own shader, so it has its own weight, which only a fit
    that measured beams has learnt: the llvmpipe fit (and the paper anchor made from it)
    prices beams, and a beam's fragments cost time under it; a set whose fit never saw a
    beam (the negative control: a copy of the llvmpipe set whose fit record lacks its
    beam configurations) does not price them, rather than pricing them at its 0, and
    ``cost_ratio`` compares a beams frame under the sets that price both."""
    import dataclasses

    from volcaustics.approx.cost_model import predicted_frames
    from volcaustics.reports.measuring.cost_match import cost_ratio

    sets = weight_sets()
    beams = dataclasses.replace(PAPER, splat="beams").resolved(_scene("sphere1"))
    counts = dict(sets["paper_gpu"].provenance["paper_counts"])
    for name in ("llvmpipe", "paper_gpu"):
        assert sets[name].prices(beams)
        more = {**counts, "shaded_splat": 4 * counts["shaded_splat"]}  # a beam pass is priced by what it shades
        assert sets[name].frame(more, beams) > sets[name].frame(counts, beams)
    assert features(counts, beams)["splat"]["beam_fragments"] == counts["shaded_splat"] != counts["fragments_splat"]
    for uncounted in (None, float("nan")):  # a driver without pipeline statistics, or a stored summary's null
        assert features({**counts, "shaded_splat": uncounted}, beams)["splat"]["beam_fragments"] == \
            counts["fragments_splat"]
    llvmpipe = sets["llvmpipe"]
    configs = {k: v for k, v in llvmpipe.provenance["fit"]["configs"].items() if v.get("splat") != "beams"}
    provenance = {k: v for k, v in llvmpipe.provenance.items() if k != "splat_modes"}
    unaware = dataclasses.replace(llvmpipe, name="unaware",
                                  provenance={**provenance, "fit": {**provenance["fit"], "configs": configs}})
    assert not unaware.prices(beams) and unaware.prices(PAPER)
    both = {"llvmpipe": llvmpipe, "unaware": unaware}
    own = predicted_frames(counts, beams, both)
    paper = predicted_frames(counts, PAPER.resolved(_scene("sphere1")), both)
    assert set(own) == {"llvmpipe"} and set(paper) == {"llvmpipe", "unaware"}
    assert cost_ratio(own, paper) == pytest.approx(own["llvmpipe"] / paper["llvmpipe"])
    with pytest.raises(ValueError, match="no weight set prices both"):
        cost_ratio({}, paper)


def test_differential_beams_have_a_fragment_weight_of_their_own():
    """A differential beam's fragment integrates its kernel over the pixel, another shader
    than a fixed beam's point sample: the llvmpipe fit measured both and prices each
    fragment by its own weight (on llvmpipe within 1% of each other: most fragments are
    discarded before the kernel); a set whose fit measured fixed beams only (the negative
    control) does not price differential beams, rather than at its 0."""
    import dataclasses

    sets = weight_sets()
    fixed = dataclasses.replace(PAPER, splat="beams").resolved(_scene("sphere1"))
    differential = dataclasses.replace(fixed, beam_width="differential")
    counts = dict(sets["paper_gpu"].provenance["paper_counts"])
    assert features(counts, differential)["splat"]["own_beam_fragments"] == counts["shaded_splat"]
    assert features(counts, differential)["splat"]["beam_fragments"] == 0.0
    assert features(counts, fixed)["splat"]["own_beam_fragments"] == 0.0
    llvmpipe = sets["llvmpipe"]
    assert llvmpipe.prices(differential) and sets["paper_gpu"].prices(differential)
    more = {**counts, "shaded_splat": 4 * counts["shaded_splat"]}  # priced by what it shades
    assert llvmpipe.frame(more, differential) > llvmpipe.frame(counts, differential)
    configs = {k: v for k, v in llvmpipe.provenance["fit"]["configs"].items()
               if v.get("beam_width", "fixed") == "fixed"}
    provenance = {k: v for k, v in llvmpipe.provenance.items() if k != "splat_modes"}
    fixed_only = dataclasses.replace(llvmpipe, name="fixed beams only",
                                     provenance={**provenance, "fit": {**provenance["fit"], "configs": configs}})
    assert fixed_only.prices(fixed) and not fixed_only.prices(differential)


def _shipped(name: str = "llvmpipe") -> dict:
    with open(os.path.join(WEIGHTS_DIR, f"{name}.json"), encoding="utf-8") as fh:
        return json.load(fh)


def _with_provenance(**changes) -> dict:
    doc = _shipped()
    return {**doc, "provenance": {**doc["provenance"], **changes}}


@pytest.mark.parametrize("doc, says", [
    ({**_shipped(), "provenance": [1, 2]}, "provenance = [1, 2]"),              # read as an object: AttributeError
    (_with_provenance(splat_modes="fixed"), 'provenance.splat_modes = "fixed"'),  # iterated per character
    (_with_provenance(splat_modes=3), "provenance.splat_modes = 3"),             # TypeError
    (_with_provenance(splat_modes=[]), "provenance.splat_modes = []"),           # prices no frame
    (_with_provenance(splat_modes=["beam"]), 'provenance.splat_modes = ["beam"]'),
    (_with_provenance(fit=[]), "provenance.fit = []"),
    (_with_provenance(fit={"configs": {"a": "splat=beams"}}), "provenance.fit.configs = "),
    ({**_shipped(), "weights": {}}, "weights = {}: no weight > 0"),              # ZeroDivisionError in cost_ratio
    ({"weights": {"density": {"splats": 1.0}}}, "no weight > 0 on what every frame counts"),  # 0 but for density
    ({"weights": {"trace": {"calls": 1e308}}}, "weights.trace.calls = 1e+308"),  # the sum overflows: NaN to int
    ({"weights": {"trace": {"calls": 1e-300}}}, "weights.trace.calls = 1e-300"),  # a ratio against it overflows
    ({**_shipped(), "name": 3}, "name = 3"),
    ({**_shipped(), "unit": ""}, 'unit = ""'),
    ({**_shipped(), "weight": {}}, "unknown key 'weight'"),
    ([1], "holds list [1]"),
])
def test_every_defect_of_a_weight_file_is_bad_input_naming_file_key_and_value(tmp_path, doc, says):
    """The whole document is checked when read: each defect is an InputError (exit 2 on the
    command line) naming the file, the key and the value, never a traceback later or a set
    that silently prices nothing."""
    path = tmp_path / "mine.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError) as exc:
        read_weight_set(str(path))
    assert str(path) in str(exc.value) and says in str(exc.value), str(exc.value)


def test_the_weight_bounds_keep_every_frame_and_its_ratio_finite():
    """The bounds' analysis (cost_model.MIN_WEIGHT, MAX_WEIGHT): every feature weighed at
    MAX_WEIGHT with every count at 2^64 and every size at the parameter table's maximum
    prices a finite frame, and its ratio to the cheapest frame a set can price (one
    always-counted feature at MIN_WEIGHT, every size at its minimum) is finite; the
    shipped sets lie within the bounds."""
    from volcaustics.reports.measuring.cost_match import cost_ratio

    sizes = ("photon_res", "steps", "width", "height", "fog_steps", "layers", "light_res", "fresnel_splits")
    largest = dataclasses.replace(PAPER, splat="density", **{n: param(n).high for n in sizes})
    smallest = dataclasses.replace(PAPER, splat="fixed", **{n: param(n).low for n in sizes})
    counts = dict.fromkeys(weight_sets()["paper_gpu"].provenance["paper_counts"], float(2**64))
    heavy = WeightSet("heavy", "s", {p: dict.fromkeys(fs, MAX_WEIGHT) for p, fs in features(counts, largest).items()})
    calls = next(p for p, fs in always_counted().items() if "calls" in fs)
    light = WeightSet("light", "s", {calls: {"calls": MIN_WEIGHT}})
    top, bottom = heavy.frame(counts, largest), light.frame(dict.fromkeys(counts, 0.0), smallest)
    assert math.isfinite(top) and bottom >= MIN_WEIGHT
    assert math.isfinite(cost_ratio({"x": top}, {"x": bottom}))
    for ws in weight_sets().values():
        assert all(w == 0 or MIN_WEIGHT <= w <= MAX_WEIGHT for fs in ws.weights.values() for w in fs.values())
