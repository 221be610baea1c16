"""`volcaustics report`: a self-contained page and summary.json drawn from results, the
gate's verdicts on it, a warm rerun that measures nothing, a sweep section, bad input
that exits 2 before rendering, and the page opened in a real headless Chromium."""

from __future__ import annotations

import json
import os
import re
import shutil
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from tests.shared import FAST_MEASUREMENT, with_shared_references
from tests.shared import SWEEP_SPEC as SPEC
from volcaustics.reports.cli import main
from volcaustics.reports.presenting.page.parts import debiased_pct
from volcaustics.scenes.formats import COLOUR_LAYERS

REPO = Path(__file__).resolve().parents[2]
SCENES = ("refocus", "sphere1")
# tiny experiments: 40², photon_res/light_res 64, 2 seeds, one exact replay per texel; references of 4
# fixed batches with the report's 8 scattering orders (the page's model term is under test)
SMALL = ["--set", "width=40", "--set", "height=40", "--set", "photon_res=64", "--set", "light_res=64",
         "--seeds", "2", *FAST_MEASUREMENT, "--photons", "65536", "--spp", "8", "--batches", "4", "--target-noise",
         "none", "--quiet"]
# refocus passes everything; sphere1's HDR-FLIP budget is far below what any frame gets (≈ 0.8): one failure
BUDGETS = """
preset = "quick"
seeds = 2
[scene.refocus]
caustic = { energy_ratio = [0.0, 10.0], hdr_flip_max = 1.0 }
segments = { missed_step2_max = 1.0 }
[scene.sphere1]
caustic = { hdr_flip_max = 0.001 }
combined = { energy_ratio = [0.0, 10.0] }
"""
SWEEP = SPEC.replace("iterations = [4, 8]\n", "")  # tiny points over layers 1, 2
# the frames `compare` is given: the approximation at the report's size, paper preset (another renderer's settings)
COMPARED = ["--width", "40", "--height", "40", "--photon-res", "64", "--light-res", "64"]
# a tiny animation for the "Over time" section: 3 refocus frames at 40²
ANIMATE = ["--frames", "3", "--width", "40", "--height", "40", "--photon-res", "64", "--light-res", "64",
           "--photons", "65536", "--spp", "8", "--batches", "4", "--quiet"]


@pytest.fixture(scope="module")
def built(tmp_path_factory, shared_references):
    """One sweep store and one report over it (cold), then the same report again (warm)."""
    root = tmp_path_factory.mktemp("report")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VOLCAUSTICS_CACHE", str(with_shared_references(root / "cache", shared_references)))
        (root / "sweep.toml").write_text(SWEEP)
        (root / "budgets.toml").write_text(BUDGETS)
        assert main(["sweep", str(root / "sweep.toml"), "-o", str(root / "sweep"), "--workers", "1", "--quiet"]) == 0
        assert main(["animate", "refocus", "-o", str(root / "animation"), *ANIMATE]) == 0
        for seed in (0, 1):  # another renderer's files: the approximation's own, through `compare`
            assert main(["approx", "refocus", "-o", str(root / f"shot{seed}.exr"), *COMPARED, "--seed", str(seed),
                         "--records-max", "0"]) == 0
        assert main(["compare", "refocus", str(root / "shot0.exr"), str(root / "shot1.exr"), "-o",
                     str(root / "compared" / "refocus"), *SMALL[SMALL.index("--photons"):]]) == 0
        args = ["report", "--scenes", ",".join(SCENES), "--budgets", str(root / "budgets.toml"),
                "--sweep", str(root / "sweep"), "--animation", str(root / "animation"),
                "--compare", f"files={root / 'compared'}", *SMALL]
        assert main([*args, "--out", str(root / "cold")]) == 0
        cold = json.loads((root / "cold" / "summary.json").read_text())
        assert main([*args, "--out", str(root / "warm")]) == 0
        warm = json.loads((root / "warm" / "summary.json").read_text())
        yield {"root": root, "args": args, "cold": cold, "warm": warm,
               "page": (root / "cold" / "index.html").read_text()}


class _Page(HTMLParser):
    """The overview's cells per row, every <img> and every external reference."""

    def __init__(self):
        super().__init__()
        self.rows, self.images, self.external, self._cell, self._in_overview = [], [], [], None, False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table" and a.get("id") == "overview":
            self._in_overview = True
        if self._in_overview and tag == "tr" and "data-scene" in a:
            self.rows.append({"scene": a["data-scene"], "cells": []})
        if self._in_overview and tag == "td" and self.rows:
            self._cell = []
        if tag == "img":
            self.images.append(a)
        for key in ("src", "href"):
            value = a.get(key) or ""
            if tag in ("script", "link", "img", "iframe") and value and not value.startswith(("data:", "#")):
                self.external.append((tag, value))

    def handle_endtag(self, tag):
        if tag == "td" and self._cell is not None:
            self.rows[-1]["cells"].append("".join(self._cell).strip())
            self._cell = None
        if tag == "table":
            self._in_overview = False

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def _parse(page: str) -> _Page:
    parser = _Page()
    parser.feed(page)
    return parser


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_document_reads_back_as_written(built):
    """summary.json read into the report's types and written back is the file, key for key
    and in its order (sweep, animations, comparisons and all); a part edited in the types
    is in what they write."""
    import dataclasses

    from volcaustics.reports.measuring.results.tables import plain
    from volcaustics.reports.presenting.page.report_document import ReportDocument

    cold = built["cold"]
    document = ReportDocument.from_json(cold)
    assert json.dumps(plain(document.to_json())) == json.dumps(cold)
    assert document.scenes[0].components["caustic"].estimate("relative_mse").value > 0
    edited = dataclasses.replace(document, seeds=document.seeds + 1)
    assert plain(edited.to_json())["seeds"] == cold["seeds"] + 1


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_summary_holds_every_scene_and_the_gate_verdicts(built):
    s = built["cold"]
    assert [p["scene"] for p in s["scenes"]] == list(SCENES)
    assert s["seeds"] == 2 and s["params"]["width"] == 40 and s["reference_settings"]["batches"] == 4
    assert s["measurement"]["exact_subphotons"] == 1  # the measurement settings it was given
    by_scene = {p["scene"]: p for p in s["scenes"]}
    assert by_scene["refocus"]["gate"]["passed"] is True
    failed = [c for c in by_scene["sphere1"]["gate"]["checks"] if not c["passed"]]
    assert [c["name"] for c in failed] == ["caustic.hdr_flip_max"]
    # failures first within a scene
    assert by_scene["sphere1"]["gate"]["checks"][0]["passed"] is False
    assert s["gate"] == {"passed": False, "checks": 5, "failed": 1, "unchecked_scenes": [],
                         "scenes_without_budgets": []}
    for page in s["scenes"]:
        assert page["measured_in_this_run"] is True
        # the decomposition's terms telescope to its total (an identity of the estimator, to rounding)
        terms = page["decomposition"]["terms"]
        assert sum(t["energy_share"] for t in terms) == pytest.approx(page["decomposition"]["total"]["energy_share"],
                                                                       abs=1e-9)
        # hit classes of a step (self re-hits counted by their class beyond) are every segment of it
        for step in page["hit_classes"]["by_step"]:
            shares = [step[c] for c in ("true_hit", "wrong_surface", "false_hit", "missed_inside", "missed_medium",
                                        "correct_miss")]
            assert sum(shares) == pytest.approx(100.0, abs=1e-9)
        by_layer = {}
        for row in page["hit_classes"]["rows"]:
            by_layer[row["step"]] = by_layer.get(row["step"], 0) + row["segments"]
        assert by_layer == {r["step"]: r["segments"] for r in page["hit_classes"]["by_step"]}
        passes = {p["pass"]: p for p in page["timing"]["passes"]}
        assert {"trace", "splat", "other"} <= set(passes)
        # one frame's passes (finish + wall clock each) fit in its frame time: "other" is what is left, ≥ 0
        inside = sum(p["seconds"] for name, p in passes.items() if name != "other")
        assert 0 < inside <= page["timing"]["frame_s"] and passes["other"]["seconds"] >= 0


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_page_shows_the_summary_numbers(built):
    """Every overview cell is the summary's number as the page formats it."""
    s, parsed = built["cold"], _parse(built["page"])
    assert [r["scene"] for r in parsed.rows] == [p["scene"] for p in s["scenes"] for _ in range(4)]
    rows = iter(parsed.rows)
    for page in s["scenes"]:
        for component in ("caustic", "fog", "direct", "combined"):
            cells = next(rows)["cells"]
            if component == "caustic":
                assert cells[0] == page["scene"]
                cells = cells[1:]
            c = page["components"][component]
            assert cells[0] == component
            mean = c["relative_mse"]  # a negative estimate reads "≤ noise (…)" (parts.debiased_pct)
            assert cells[1] == debiased_pct(mean["debiased"], low=mean["ci_low"], high=mean["ci_high"])
            frame = c["frame_relative_mse"]  # one frame's error beside the mean's
            assert cells[2] == debiased_pct(frame["debiased"], se=frame["standard_error"])
            assert cells[3] == f"{100 * c['reference_noise_floor']:.3f}%"
            assert cells[4].startswith(f"{c['energy_ratio']['value']:.3f}")
            assert cells[5] == f"{c['hdr_flip']['value']:.3g}"
            model = page["model"]["components"][component]  # the single-scattering model's own error
            assert cells[6] == (f"{debiased_pct(model['relmse_own']['debiased'])} "
                                f"({100 * model['energy_share']['value']:.1f}%)")
            # the caustic's error by cause, emission first, and whether the residual closes
            d = page["decomposition"]
            if component == "caustic":
                # a term exactly 0 is left out: the built-ins are homogeneous, so march and camera_volume
                absent = {t["term"] for t in d["terms"] if t["energy_share"] == 0.0 and t["relmse_part"] == 0.0}
                assert {"march", "camera_volume"} <= absent
                parts = [f"{t['term'].replace('_', ' ')} {100 * t['relmse_part_debiased']:+.2f}" for t in d["terms"]
                         if t["term"] not in absent]
                assert [t["term"] for t in d["terms"]][0] == "emission"
                closes = "✓ pass closes" if d["residual"]["within_noise"] else "✗ FAIL does not close"
                assert cells[7] == "".join(parts) + closes
            else:
                assert cells[7] == ""
    for page in s["scenes"]:  # the model term beside the decomposition, with the orders it took
        model = page["model"]
        assert model["max_scatter"] == 8 and set(model["orders_needed"]) == {"caustic", "fog", "direct"}
        assert f"<h3>The single-scattering model against {model['max_scatter']} scattering orders</h3>" \
            in built["page"]
    # the failure is spelled out, not only coloured, and comes first in its cell and in the banner
    assert "✗ Gate FAILED: 1 of 5 checks" in built["page"]
    sphere = next(r for r in parsed.rows if r["scene"] == "sphere1" and len(r["cells"]) > 6)
    assert sphere["cells"][9].startswith("✗ FAIL caustic.hdr_flip_max")


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_page_is_self_contained(built):
    parsed = _parse(built["page"])
    assert parsed.external == []
    assert not re.search(r"https?://", built["page"])
    figures = [f for f in built["cold"]["sweep"]["figures"] if f.endswith(".png")]
    # per scene: 5 renders, 4 maps, 4 charts; the animation: its video and its plot; the other renderer: its
    # and the reference's caustic and combined, 4 maps; the first screen's chart
    assert len(parsed.images) == 2 * (5 + 4 + 4) + len(figures) + 2 + 8 + 1
    assert all(img["src"].startswith(("data:image/png;base64,", "data:image/webp;base64,", "data:image/gif;base64,"))
               for img in parsed.images)
    renders = [img for img in parsed.images if "render" in img.get("class", "")]
    assert renders and all("swap" not in img["class"] or img.get("data-other") for img in renders)
    assert "image-rendering:pixelated" in built["page"]


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_another_renderer_beside_the_approximation(built):
    """`report --compare files=DIR`: one more row for refocus in the Renderers table, its
    numbers those `compare` wrote, its images in refocus's section; sphere1 has none."""
    compared = json.loads((built["root"] / "compared" / "refocus" / "summary.json").read_text())
    rows = built["cold"]["comparisons"]
    assert [(r["renderer"], r["scene"]) for r in rows] == [("files", "refocus")]
    for component in COLOUR_LAYERS:
        assert rows[0]["images"][component]["relative_mse"] == compared["images"][component]["relative_mse"]
    page = built["page"]
    table = page[page.index("id='renderers-table'"):page.index("</table>", page.index("id='renderers-table'"))]
    assert table.count("class='renderer-row'") == 2 and "data-scene='sphere1'" not in table
    assert f"{100 * compared['images']['caustic']['relative_mse']['debiased']:.2f}%" in table
    section = page[page.index("id='scene-0'"):page.index("id='scene-1'")]
    assert "id='compare-0'" in section and "files on refocus" in section
    assert "id='compare-0-renderer-caustic'" in section and "id='compare-0'" not in page[page.index("id='scene-1'"):]


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_a_comparison_the_report_cannot_show_exits_2(built, tmp_path, capsys):
    """A comparison of a scene the report does not show, or one edited since written
    (its summary's own SHA-256), exits 2 before anything renders."""
    folder = built["root"] / "compared" / "refocus"
    args = [a for a in built["args"] if a != "--compare" and not a.startswith("files=")]
    scenes = args.index("--scenes") + 1
    only_sphere = [*args[:scenes], "sphere1", *args[scenes + 1:]]
    assert main([*only_sphere, "--compare", f"files={folder}", "--out", str(tmp_path / "a")]) == 2
    assert "which this report does not show" in capsys.readouterr().err
    edited = tmp_path / "edited"
    shutil.copytree(folder, edited)
    doc = json.loads((edited / "summary.json").read_text())
    doc["images"]["caustic"]["energy_ratio"]["value"] = 1.0
    (edited / "summary.json").write_text(json.dumps(doc))
    assert main([*args, "--compare", f"files={edited}", "--out", str(tmp_path / "b")]) == 2
    assert "SHA-256" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_over_time_section(built):
    """An animation measured by `animate` shows as "Over time": its embedded animated
    WebP, its plot and its flicker numbers, the same as its own summary.json."""
    rows = built["cold"]["animations"]
    assert [r["scene"] for r in rows] == ["refocus"] and not rows[0]["stale"]
    own = json.loads((built["root"] / "animation" / "summary.json").read_text())
    assert rows[0]["metrics"] == own["metrics"]
    page = built["page"]
    assert "<section id='over-time'>" in page and "href='#over-time'" in page
    assert "src='data:image/webp;base64," in page or "src='data:image/gif;base64," in page
    flicker = own["metrics"]["fixed"]["caustic"]["flicker"]
    assert f"{100 * flicker:.2f}%" in page


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_sweep_section(built):
    sweep = built["cold"]["sweep"]
    assert sweep["varied"] == ["layers"] and sweep["points"] == 2
    assert {r["parameter"] for r in sweep["suffice"]} == {"layers"}
    assert {r["suffices"] for r in sweep["suffice"]} <= {1, 2}
    assert all(r["error"] <= 1.1 * r["best"] + 1e-12 for r in sweep["suffice"])
    for rel in sweep["figures"]:
        assert (built["root"] / "cold" / rel).stat().st_size > 0
    assert "Settings that suffice" in built["page"] and "id='suffice'" in built["page"]


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_a_report_keeps_only_its_own_figures(built):
    """An earlier --sweep's figures do not outlive it: a report rewritten with a sweep keeps
    just this sweep's figures (and files that are not figures); without one, none."""
    out = built["root"] / "figures-rerun"
    (out / "figures").mkdir(parents=True)
    (out / "figures" / "variants_old.png").write_bytes(b"stale")
    (out / "figures" / "notes.txt").write_text("mine")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VOLCAUSTICS_CACHE", str(built["root"] / "cache"))
        assert main([*built["args"], "--out", str(out)]) == 0
        drawn = json.loads((out / "summary.json").read_text())["sweep"]["figures"]
        assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(
            [Path(rel).name for rel in drawn] + ["notes.txt"])
        args = [a for i, a in enumerate(built["args"]) if a != "--sweep" and built["args"][i - 1] != "--sweep"]
        assert main([*args, "--out", str(out)]) == 0
    assert sorted(p.name for p in (out / "figures").iterdir()) == ["notes.txt"]


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_a_warm_report_measures_nothing_and_says_the_same(built):
    cold, warm = built["cold"], built["warm"]
    assert [p["measured_in_this_run"] for p in warm["scenes"]] == [False, False]
    strip = ("measured_in_this_run",)
    for a, b in zip(cold["scenes"], warm["scenes"]):
        assert {k: v for k, v in a.items() if k not in strip} == {k: v for k, v in b.items() if k not in strip}
    # and draws no picture: each scene's pictures come from the cache, the very same ones
    assert len(list((built["root"] / "cache" / "page-images").glob("*.json"))) == len(cold["scenes"])
    images = [re.findall(r"src='(data:[^']+)'", (built["root"] / run / "index.html").read_text())
              for run in ("cold", "warm")]
    assert images[0] == images[1]


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_a_point_measured_again_draws_its_pictures_again(built, monkeypatch, tmp_path):
    """Negative control for the pictures' cache: a stored summary that changed (a point
    measured again: another seal) is a new cache entry, not the old pictures."""
    from types import SimpleNamespace

    from volcaustics.reports.presenting.page import page_write as write

    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path))
    drawn = []
    monkeypatch.setattr(write, "scene_images", lambda result, page: drawn.append(result.key) or {"x": "y"})
    result = SimpleNamespace(key="k", experiment=SimpleNamespace(summary_sha256="a" * 64))
    assert write.cached_scene_images(result, {}) == {"x": "y"} and drawn == ["k"]
    assert write.cached_scene_images(result, {}) == {"x": "y"} and drawn == ["k"]   # from the cache
    result.experiment = SimpleNamespace(summary_sha256="b" * 64)
    write.cached_scene_images(result, {})
    assert drawn == ["k", "k"]


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_a_damaged_stored_result_is_measured_again(built, monkeypatch):
    root = built["root"]
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(root / "cache"))
    key = next(p["point"] for p in built["cold"]["scenes"] if p["scene"] == "refocus")
    views = root / "cache" / "report-results" / "points" / key / "views.exr"
    views.write_bytes(views.read_bytes()[:1000])        # torn
    assert main([*built["args"], "--out", str(root / "again")]) == 0
    again = json.loads((root / "again" / "summary.json").read_text())
    assert {p["scene"]: p["measured_in_this_run"] for p in again["scenes"]} == {"refocus": True, "sphere1": False}
    first = next(p for p in built["cold"]["scenes"] if p["scene"] == "refocus")
    second = next(p for p in again["scenes"] if p["scene"] == "refocus")
    assert second["components"] == first["components"]   # same seeds, same reference: the same numbers


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_page_survives_missing_numbers_and_odd_names(built):
    """A metric the store holds as null (NaN), a map that was not computed and a scene
    named with quotes and markup: the page still renders, shows "–", escapes the name
    and keeps its ids and swaps working (ids are by position, not by name)."""
    import copy

    from volcaustics.reports.presenting.page.html import render_page
    from volcaustics.reports.presenting.page.report_document import ReportDocument

    summary = copy.deepcopy(built["cold"])
    page = summary["scenes"][0]
    odd = "a'b\"<c>#%"
    page["scene"] = odd
    page["components"]["caustic"]["relative_mse"]["debiased"] = None
    page["decomposition"]["terms"][0]["energy_share"] = None
    page["decomposition"]["residual"]["energy_z"] = None
    page["reference"]["photons"] = None
    page["timing"]["frame_s"] = None
    images = {p["scene"]: {f"approx.{c}": "data:image/png;base64,AA" for c in ("caustic", "combined")}
              for p in summary["scenes"]}
    for name in images:
        for key in ("reference.caustic", "reference.combined", "exact_steps", "chart.hit_classes",
                    "chart.power_budget", "chart.decomposition", "chart.pass_times"):
            images[name][key] = "data:image/png;base64,AA"
        for metric in ("per_pixel_relative_mse", "hdr_flip"):
            for c in ("caustic", "combined"):
                images[name][f"map.{metric}.{c}"] = None       # not computed
    html = render_page(ReportDocument.from_json(summary), images, {})
    parsed = _parse(html)
    assert {r["scene"] for r in parsed.rows} == {odd, "sphere1"}
    assert odd not in html                                  # only escaped
    assert "not computed" in html and "<td>–" in html
    assert all(img.get("id", "s").startswith("s") for img in parsed.images)


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_gate_with_a_baseline_keeps_budget_failures(built, monkeypatch, tmp_path):
    """A regression test where the baseline has the scene, a note where it has not;
    the budget failure stays whatever the regression part finds."""
    root = built["root"]
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(root / "cache"))
    sphere = next(p for p in built["cold"]["scenes"] if p["scene"] == "sphere1")
    per_seed = sphere["components"]["caustic"]["relative_mse"]["per_seed"]
    baseline = tmp_path / "baseline"
    baseline.mkdir()
    (baseline / "baseline.json").write_text(json.dumps({"format": 1, "scenes": {"sphere1": {
        "reference_key": sphere["reference"]["key"], "seeds": sphere["seed_values"],
        "caustic_relmse_per_seed": per_seed}}}))
    assert main([*built["args"], "--baseline", str(baseline), "--out", str(tmp_path / "out")]) == 0
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    by_scene = {p["scene"]: p["gate"] for p in s["scenes"]}
    names = {c["name"]: c["passed"] for c in by_scene["sphere1"]["checks"]}
    # the same frames as the baseline's: the paired test sees no change at all
    assert names["regression.caustic_relmse"] is True and names["caustic.hdr_flip_max"] is False
    assert "no entry" in by_scene["refocus"]["note"] and by_scene["refocus"]["passed"] is True
    assert s["gate"]["passed"] is False and s["baseline"] == str(baseline)


@pytest.mark.parametrize("argv, fragment", [
    (["--scenes", ""], "--scenes"),
    (["--scenes", "refocus,"], "--scenes"),
    (["--scenes", "no_such_scene"], "no_such_scene"),
    (["--scenes", "refocus,refocus"], "twice"),
    (["--seeds", "0"], "--seeds"),
    (["--set", "layers=0"], "layers"),
    (["--set", "seed=3"], "--seed"),
    (["--sweep", "/nonexistent/sweep"], "sweep.json"),
    (["--animation", "/nonexistent/animation"], "volcaustics animate"),
    (["--compare", "/nonexistent/compared"], "expected NAME=DIR"),
    (["--compare", "x=/nonexistent/compared"], "volcaustics compare"),
    (["--baseline", "/nonexistent/baseline"], "baseline"),
    (["--budgets", "BUDGETS_NAMING_NOSUCH"], "scene.nosuch"),  # a budgets file with an unknown scene
])
def test_bad_input_exits_2_before_rendering(tmp_path, monkeypatch, capsys, argv, fragment):
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path / "cache"))
    if "BUDGETS_NAMING_NOSUCH" in argv:
        (tmp_path / "b.toml").write_text(BUDGETS + "[scene.nosuch]\ncaustic = { hdr_flip_max = 1.0 }\n")
        argv = [str(tmp_path / "b.toml") if a == "BUDGETS_NAMING_NOSUCH" else a for a in argv]
    assert main(["report", "--out", str(tmp_path / "out"), "--scenes", "refocus", *argv, "--quiet"]) == 2
    assert fragment in capsys.readouterr().err
    assert not (tmp_path / "cache" / "reference").exists() or not list((tmp_path / "cache" / "reference").iterdir())


def test_an_output_that_is_a_file_exits_2(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    assert main(["report", "--out", str(target), "--quiet"]) == 2
    assert "--out" in capsys.readouterr().err


# --- the page in a real browser ----------------------------------------------------------

def _browser():
    """A headless Chromium driven by Selenium, or the reason there is none."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not chromium or not driver:
        return None, ("Chromium or chromedriver not installed (Debian packages chromium, chromium-driver; "
                      "scripts/setup.sh installs them when run as root)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError as exc:
        return None, f"selenium not importable ({exc}): pip install -e '.[test]'"
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--window-size=1366,768", "--allow-file-access-from-files"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        return webdriver.Chrome(service=Service(driver), options=options), None
    except Exception as exc:  # a driver that cannot start is a reason to skip, stated
        return None, f"Chromium did not start under chromedriver: {exc}"


@pytest.mark.slow  # a browser: `make test-fast` skips it
def test_the_report_in_headless_chromium(built):
    """Opens the page at 1366×768: no console errors, every image decodes, the overview
    lists every scene, hovering an approximation shows the reference; a screenshot is
    kept under test-output/."""
    browser, reason = _browser()
    if browser is None:
        pytest.skip(reason)
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    try:
        browser.get((built["root"] / "cold" / "index.html").as_uri())
        browser.execute_script("return document.readyState")
        undecoded = browser.execute_script(
            "return Array.from(document.images).filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt)")
        assert undecoded == []
        assert browser.execute_script("return document.images.length") == len(_parse(built["page"]).images)
        listed = browser.execute_script(
            "return Array.from(new Set(Array.from(document.querySelectorAll('#overview tr[data-scene]'))"
            ".map(r => r.dataset.scene)))")
        assert listed == list(SCENES)
        # the animation plays: an animated image of the 3 frames, decoded, in the "Over time" section
        video = browser.find_element(By.CSS_SELECTOR, "#over-time img.animation-video")
        assert browser.execute_script("return arguments[0].naturalWidth", video) > 0
        assert len(browser.find_elements(By.CSS_SELECTOR, "#over-time table.over-time-table tr")) == 1 + 2 * 2
        # readable at 1366×768: nothing wider than the window
        assert browser.execute_script("return document.documentElement.scrollWidth <= "
                                      "document.documentElement.clientWidth")
        approx = browser.find_element(By.ID, "s0-approx-caustic")      # refocus, the first scene
        reference = browser.find_element(By.ID, "s0-reference-caustic")
        own, theirs = approx.get_attribute("src"), reference.get_attribute("src")
        assert own != theirs
        caption = browser.find_element(By.ID, "s0-approx-caustic-label")
        away = browser.find_element(By.CSS_SELECTOR, "#scene-0 h2")

        def hover(element):
            browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", element)
            ActionChains(browser).move_to_element(element).perform()

        hover(approx)          # hovering shows the reference in its place
        assert approx.get_attribute("src") == theirs and "reference" in caption.text
        hover(away)
        assert approx.get_attribute("src") == own and "approximation" in caption.text
        approx.click()         # a click keeps the reference after the pointer leaves
        hover(away)
        assert approx.get_attribute("src") == theirs
        approx.click()
        hover(away)
        assert approx.get_attribute("src") == own
        other = browser.find_element(By.ID, "compare-0-renderer-caustic")   # another renderer swaps the same way
        hover(other)
        assert other.get_attribute("src") == browser.find_element(By.ID, "compare-0-reference-caustic") \
            .get_attribute("src")
        assert "reference" in browser.find_element(By.ID, "compare-0-renderer-caustic-label").text
        hover(away)
        assert "showing: files" in browser.find_element(By.ID, "compare-0-renderer-caustic-label").text
        browser.execute_script("window.scrollTo(0, 0)")
        out = REPO / "test-output"
        out.mkdir(exist_ok=True)
        assert browser.save_screenshot(str(out / "report.png"))
        errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        assert errors == []
    finally:
        browser.quit()


def test_error_maps_average_to_their_metric():
    """full=True maps: their mean over the compared pixels is the metric's value."""
    from volcaustics.metrics.image import hdr_flip, per_pixel_relative_mse

    rng = np.random.default_rng(4)
    r = rng.uniform(0.1, 1.0, (24, 32, 3))
    t = r * rng.uniform(0.8, 1.25, r.shape)
    keep = np.ones((24, 32), bool)
    keep[:6] = False
    for metric in (per_pixel_relative_mse, hdr_flip):
        out = metric(r, t, mask=keep, full=True)
        assert out["map"].shape == (24, 32) and np.isnan(out["map"][:6]).all()
        assert np.nanmean(out["map"]) == pytest.approx(out["value"], rel=1e-12)
        assert metric(r, t, mask=keep)["value"] == out["value"] and "map" not in metric(r, t, mask=keep)


def test_report_and_reference_cli_share_one_cache_entry(tmp_path, monkeypatch, capsys):
    """Image size lives in the settings (docs/architecture.md): the report's reference and
    `volcaustics reference --width/--height` at the same size are one render, one key,
    one cache entry — whichever path comes first, the other is served from the cache."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(cache))
    budget = ["--photons", "100000", "--spp", "8", "--batches", "2", "--max-scatter", "2"]
    budgets = tmp_path / "budgets.toml"  # none for refocus: the terminal says why the gate did not check it
    budgets.write_text('preset = "quick"\n[scene.sphere1]\ncaustic = { hdr_flip_max = 1.0 }\n')
    assert main(["report", "--out", str(tmp_path / "rep"), "--scenes", "refocus", "--seeds", "1", "--quiet",
                 "--set", "width=24", "--set", "height=24", "--set", "photon_res=32", "--set", "light_res=32",
                 *budget, "--target-noise", "none", "--budgets", str(budgets), *FAST_MEASUREMENT]) == 0
    assert f"gate not checked (no budgets for refocus in {budgets})" in capsys.readouterr().out
    from_report = json.loads((tmp_path / "rep" / "summary.json").read_text())["scenes"][0]["reference"]
    argv = ["reference", "refocus", "--width", "24", "--height", "24", *budget, "-o", str(tmp_path / "r.exr")]
    assert main(argv) == 0
    from_cli = json.loads((tmp_path / "r.json").read_text())
    assert from_cli["key"] == from_report["key"]
    assert from_report["cached"] is False and from_cli["cached"] is True
    assert len(list((cache / "reference").glob("*.json"))) == 1
    assert os.path.exists(tmp_path / "rep" / "index.html")


@pytest.mark.slow  # the whole report on the built-ins (about 40 s, once a run): `make test-fast` skips it
def test_the_first_screen_answers_the_question(built):
    """The page opens on every scene's caustic error by cause, then the gate's verdict; the
    parameters the scenes share are stated once, and a scene's row lists only its own."""
    page = built["page"]
    chart, banner, overview = (page.index(mark) for mark in ("id='error-by-cause'", "class='banner", "id='overview'"))
    assert chart < banner < overview
    shared = built["cold"]["scenes"][0]["shown_params"]
    assert all(p["shown_params"]["photon_res"] == shared["photon_res"] for p in built["cold"]["scenes"])
    line = page[page.index("id='shared-params'"):].split("</p>", 1)[0]
    assert f"photon_res {shared['photon_res']}" in line
    table = page[overview:page.index("</table>", overview)]
    assert "photon_res" not in table  # shared: not repeated per scene


def test_the_error_by_cause_chart_draws_negative_parts_and_missing_numbers():
    """The chart takes a part below zero (drawn leftwards), a null part and a scene without a
    one-frame error; it is a PNG."""
    import math

    from volcaustics.metrics.decomposition import TERMS
    from volcaustics.reports.presenting.page.first_screen import CauseBar, error_by_cause_chart

    parts = tuple(-0.01 if i == 0 else math.nan if i == 1 else 0.02 for i in range(len(TERMS)))
    bars = [CauseBar("a", parts, 0.08, 0.1), CauseBar("b", parts, 0.08, math.nan)]
    assert error_by_cause_chart(bars).startswith(b"\x89PNG")
