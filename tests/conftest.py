"""Shared fixtures: the one GL context (checked for GL errors around every test), the
Mitsuba variant, the caches (one folder of small references per run) and scene-file
helpers. Importing ``reference`` first picks libLLVM for Dr.Jit.

What a test measures is chosen in the open, by its arguments: ``--exact-subphotons 1``
(or ``MeasurementSettings(exact_subphotons=1)``, a ``[measurement]`` table) where it
wants speed, ``--max-scatter 1`` (``max_scatter = 1``) unless the model term is under
test; the environment only says where things live."""

from __future__ import annotations

import os
import textwrap

import pytest

import volcaustics.reference  # noqa: F401  (chooses DRJIT_LIBLLVM_PATH before anything imports drjit)
from tests.shared import BASE_SCENE, with_shared_references


@pytest.fixture(scope="session", autouse=True)
def mitsuba_variant():
    """The reference renders on llvm_ad_rgb directly (no variant probing) unless the
    environment says otherwise; tests of the probing unset it themselves."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VOLCAUSTICS_MI_VARIANT", os.environ.get("VOLCAUSTICS_MI_VARIANT") or "llvm_ad_rgb")
        yield


@pytest.fixture(scope="session")
def shared_references(tmp_path_factory):
    """The run's one folder of small references: each is rendered once per run and
    served to every test that renders through :func:`cache`. Under pytest-xdist the
    workers share it (the run's folder above each worker's); the cache writes each
    reference whole by rename, so two workers rendering one reference at once agree."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    folder = root / "shared-cache" / "reference"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    """A private, empty ``$VOLCAUSTICS_CACHE`` (not created): for tests of what a
    command leaves in the cache (nothing rendered, a damaged or missing entry)."""
    root = tmp_path / "cache"
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(root))
    return root


@pytest.fixture
def cache(empty_cache, shared_references):
    """A private ``$VOLCAUSTICS_CACHE`` (result stores, metric floors) whose
    ``reference/`` and ``meshes/`` folders are the run's shared ones
    (:func:`shared_references`, ``tests.shared.with_shared_references``)."""
    return with_shared_references(empty_cache, shared_references)


@pytest.fixture(scope="session")
def gl_context():
    from volcaustics.approx.context import shared_context

    return shared_context()


@pytest.fixture
def ctx(gl_context):
    """The session's GL context; fails a test that leaves a GL error behind."""
    assert gl_context.error == "GL_NO_ERROR"
    yield gl_context
    assert gl_context.error == "GL_NO_ERROR"


@pytest.fixture
def write_scene(tmp_path):
    """Write TOML text (default: a small valid scene) to a file; returns its path."""

    def write(text: str = BASE_SCENE, name: str = "scene.toml") -> str:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text))
        return str(path)

    return write
