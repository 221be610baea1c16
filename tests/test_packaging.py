"""The wheel installs one top-level package, ``volcaustics`` (with its shaders, scenes
and budgets), never the bare folder names that belong to other PyPI distributions."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FOLDERS = ("infra", "scenes", "approx", "reference", "metrics", "experiment", "reports")
SHIPPED_SPECS = ("reports/studies/gate/budgets.toml", "reports/studies/gate/media_budgets.toml",
                 "reports/studies/sweep/variants.toml",
                 "reports/studies/best/best.toml", "reports/studies/sweep/density.toml")


def test_every_spec_in_the_repository_is_shipped():
    """Negative control for the wheel test's list: a .toml under a package folder that the
    list does not name fails here, so a new spec cannot be left out of the package data."""
    found = {os.path.relpath(os.path.join(d, f), ROOT) for top in FOLDERS
             for d, _, fs in os.walk(os.path.join(ROOT, top))
             for f in fs if f.endswith(".toml") and os.path.basename(d) not in ("builtin", "heldout", "media")}
    assert found == set(SHIPPED_SPECS), sorted(found ^ set(SHIPPED_SPECS))


def test_the_wheel_installs_only_the_volcaustics_package(tmp_path):
    # built from a copy: setuptools writes build/ and *.egg-info/ beside the sources
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".venv*", ".git", "build", "*.egg-info", "runs",
                                                                  "__pycache__", ".pytest_cache", "test-output"))
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                           "-w", str(tmp_path), str(source)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    wheel = next(tmp_path.glob("volcaustics-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    assert {t for t in tops if not t.endswith(".dist-info")} == {"volcaustics"}, sorted(tops)
    for folder in FOLDERS:  # every folder's modules, under the namespace
        assert f"volcaustics/{folder}/__init__.py" in names, folder
    assert "volcaustics/reports/cli/__init__.py" in names and "volcaustics/reports/measuring/runner.py" in names
    data = [n for n in names if n.endswith((".glsl", ".toml", ".ply"))]
    assert any(n.startswith("volcaustics/approx/shaders/") and n.endswith(".glsl") for n in data)
    assert any(n.startswith("volcaustics/scenes/builtin/") and n.endswith(".toml") for n in data)
    for folder in ("heldout", "media"):  # the held-out and the heterogeneous media's scenes travel too
        for name in os.listdir(os.path.join(ROOT, "scenes", folder)):
            assert f"volcaustics/scenes/{folder}/{name}" in names, name
    assert "volcaustics/scenes/assets/bunny10k.ply" in names
    for weights in os.listdir(os.path.join(ROOT, "approx", "cost_weights")):  # the cost model's weight sets
        assert f"volcaustics/approx/cost_weights/{weights}" in names, weights
    for spec in SHIPPED_SPECS:  # every spec a command reads by default, so an installed wheel runs them all
        assert f"volcaustics/{spec}" in names, spec
    assert "volcaustics/py.typed" in names  # static tools read the installed package's types
    assert not [n for n in names if n.startswith(("volcaustics/tests", "volcaustics/bench"))]
    target = tmp_path / "site"
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
                           str(wheel)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    installed = {p.name for p in target.iterdir() if not p.name.endswith(".dist-info") and p.name != "bin"}
    assert installed == {"volcaustics"}, sorted(installed)
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    assert "volcaustics = volcaustics.reports.cli:main" in zipfile.ZipFile(wheel).read(entry).decode()
