"""A damaged cost-model weight file (``approx/cost_weights/``, read by ``approx.cost_model``)
on the command line: exit 2 naming the file, the key and the value, before any frame or
reference renders (``approx --preset best`` prices frames to match the paper's cost;
``measure`` and every runner command price every point's frame)."""

from __future__ import annotations

import json
import shutil

import pytest

from tests.shared import FAST_MEASUREMENT, SINGLE_SCATTERING
from volcaustics.approx import cost_model
from volcaustics.reports.cli import main


@pytest.fixture
def weight_folder(tmp_path, monkeypatch):
    """A copy of the shipped weight sets, the folder the commands read (cost_model.WEIGHTS_DIR)."""
    folder = tmp_path / "cost_weights"
    shutil.copytree(cost_model.WEIGHTS_DIR, folder)
    monkeypatch.setattr(cost_model, "WEIGHTS_DIR", str(folder))
    return folder


def add_set(folder, **changes) -> str:
    """``mine.json`` in ``folder``: the shipped llvmpipe set named mine, with ``changes``."""
    doc = {**json.loads((folder / "llvmpipe.json").read_text()), "name": "mine", **changes}
    path = folder / "mine.json"
    path.write_text(json.dumps(doc))
    return str(path)


def test_approx_best_refuses_a_weight_file_whose_provenance_is_a_list(weight_folder, empty_cache, tmp_path, capsys):
    path = add_set(weight_folder, provenance=["fitted", "by hand"])
    out = tmp_path / "x.exr"
    assert main(["approx", "refocus", "--preset", "best", "--width", "32", "--height", "32", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f'{path}: provenance = ["fitted", "by hand"]: expected an object' in err and "Traceback" not in err, err
    assert not out.exists()


def test_measure_refuses_a_weight_file_without_weights_before_any_reference(weight_folder, empty_cache, tmp_path,
                                                                             capsys):
    path = add_set(weight_folder, weights={})
    out = tmp_path / "m"
    assert main(["measure", "refocus", "-o", str(out), "--seeds", "2", "--quiet", "--width", "32", "--height", "32",
                 "--photon-res", "64", "--light-res", "64", "--photons", "65536", "--spp", "8", "--batches", "4",
                 "--target-noise", "none", *SINGLE_SCATTERING, *FAST_MEASUREMENT]) == 2
    err = capsys.readouterr().err
    assert f"{path}: weights = {{}}: no weight > 0" in err and "Traceback" not in err, err
    assert not (out / "summary.json").exists()
    assert not empty_cache.exists() or not any(empty_cache.rglob("*.exr"))  # nothing rendered


def test_approx_best_with_no_weight_set_is_bad_input(weight_folder, empty_cache, tmp_path, capsys):
    for path in weight_folder.glob("*.json"):
        path.unlink()
    out = tmp_path / "x.exr"
    assert main(["approx", "refocus", "--preset", "best", "--width", "32", "--height", "32", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{weight_folder}: holds no weight set" in err and "Traceback" not in err, err
    assert not out.exists()
