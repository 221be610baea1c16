"""The package list of the one distribution, ``volcaustics`` (metadata: pyproject.toml).

The top-level folders stay where DESIGN.md puts them and are installed as one
namespace, ``volcaustics.<folder>``: four of the five bare names (``approx``,
``reference``, ``scenes``, ``metrics``, ``reports``) belong to other PyPI
distributions, and installing them bare would overwrite those. setuptools'
``package-dir`` maps each dotted name to its folder; the list of subpackages is
found here so that a new subpackage needs no edit of this file.
"""

from setuptools import find_packages, setup

FOLDERS = ("scenes", "approx", "reference", "metrics", "reports")

packages = ["volcaustics"]
for folder in FOLDERS:
    packages += [f"volcaustics.{folder}", *(f"volcaustics.{folder}.{sub}" for sub in find_packages(folder))]

setup(packages=packages, package_dir={"volcaustics": "volcaustics", **{f"volcaustics.{f}": f for f in FOLDERS}})
