"""The package list of the one distribution, ``volcaustics`` (metadata: pyproject.toml).

The top-level folders stay where docs/architecture.md puts them and are installed as one
namespace, ``volcaustics.<folder>``; ``package/`` holds the namespace's own files (``__init__``,
``__main__``, the ``py.typed`` marker), so that no folder named ``volcaustics`` in the repository
shadows the installed package (the development install is setuptools' strict editable mode, a
link tree that static tools such as mypy and pyright follow). Most of the bare names (``approx``,
``reference``, ``scenes``, ``metrics``, ``experiment``, ``reports``) belong to other PyPI distributions, and
installing them bare would overwrite those. setuptools'
``package-dir`` maps each dotted name to its folder; the list of subpackages is
found here so that a new subpackage needs no edit of this file (data folders such as
``approx/shaders/<pass>/`` count as packages, as setuptools wants for package data).
"""

from setuptools import find_namespace_packages, setup

FOLDERS = ("infra", "scenes", "approx", "reference", "metrics", "experiment", "reports")

packages = ["volcaustics"]
for folder in FOLDERS:
    subpackages = find_namespace_packages(folder, exclude=["*__pycache__*"])
    packages += [f"volcaustics.{folder}", *(f"volcaustics.{folder}.{sub}" for sub in subpackages)]

setup(packages=packages, package_data={"volcaustics": ["py.typed"]},
      package_dir={"volcaustics": "package", **{f"volcaustics.{f}": f for f in FOLDERS}})
