"""The package list of the one distribution, ``volcaustics`` (metadata: pyproject.toml).

The top-level folders stay where DESIGN.md puts them and are installed as one
namespace, ``volcaustics.<folder>``: four of the five bare names (``approx``,
``reference``, ``scenes``, ``metrics``, ``reports``) belong to other PyPI
distributions, and installing them bare would overwrite those. setuptools'
``package-dir`` maps each dotted name to its folder; the list of subpackages is
found here so that a new subpackage needs no edit of this file (data folders such as
``approx/shaders/<pass>/`` count as packages, as setuptools wants for package data).
"""

from setuptools import find_namespace_packages, setup

FOLDERS = ("scenes", "approx", "reference", "metrics", "reports")

packages = ["volcaustics"]
for folder in FOLDERS:
    subpackages = find_namespace_packages(folder, exclude=["*__pycache__*"])
    packages += [f"volcaustics.{folder}", *(f"volcaustics.{folder}.{sub}" for sub in subpackages)]

setup(packages=packages, package_dir={"volcaustics": "volcaustics", **{f"volcaustics.{f}": f for f in FOLDERS}})
