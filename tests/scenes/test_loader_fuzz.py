"""Property-based: whatever TOML is thrown at the loader, it returns a Scene or
raises SceneError — never any other exception.

Examples are derandomised so CI is repeatable; set FUZZ_EXAMPLES=N for a longer,
random exploration (e.g. FUZZ_EXAMPLES=5000 make test).
"""

from __future__ import annotations

import copy
import os

import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

try:
    import tomllib
except ModuleNotFoundError:
    import tomli as tomllib

from tests.shared import BASE_SCENE
from volcaustics.scenes import Scene, SceneError, load_scene

BASE = tomllib.loads(BASE_SCENE)

scalars = st.one_of(
    st.booleans(), st.integers(min_value=-10**6, max_value=10**6),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
)
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=3)), max_leaves=8)


def _paths(node, prefix=()):
    """Every (container path, key) in a TOML document."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield prefix, k
        yield from _paths(v, prefix + (k,))


PATHS = list(_paths(BASE))


def _check(tmp_path, text: str):
    path = tmp_path / "fuzz.toml"
    path.write_text(text)
    try:
        result = load_scene(str(path))
    except SceneError as exc:
        assert str(path) in str(exc)  # every error names the file
        return
    assert isinstance(result, Scene)


@settings(max_examples=int(os.environ.get("FUZZ_EXAMPLES", 150)), deadline=None,
          derandomize=not os.environ.get("FUZZ_EXAMPLES"),
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edits=st.lists(st.tuples(st.sampled_from(PATHS), st.sampled_from(["set", "delete", "add"]), values),
                      min_size=1, max_size=3))
def test_mutated_documents_fail_cleanly(tmp_path, edits):
    doc = copy.deepcopy(BASE)
    for (prefix, key), action, value in edits:
        node = doc
        try:
            for k in prefix:
                node = node[k]
            if action == "set":
                node[key] = value
            elif action == "delete":
                del node[key]
            elif isinstance(node, dict):
                node[f"extra_{key}"] = value
        except (KeyError, IndexError, TypeError):
            continue  # an earlier edit removed or replaced this part
    try:
        text = tomli_w.dumps(doc)
    except (TypeError, ValueError):
        return  # not representable in TOML (e.g. a list mixing tables and scalars)
    _check(tmp_path, text)


@settings(max_examples=int(os.environ.get("FUZZ_EXAMPLES", 150)), deadline=None,
          derandomize=not os.environ.get("FUZZ_EXAMPLES"),
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.integers(min_value=0, max_value=len(BASE_SCENE)), junk=st.text(max_size=30))
def test_truncated_and_spliced_text_fails_cleanly(tmp_path, cut, junk):
    _check(tmp_path, BASE_SCENE[:cut] + junk + BASE_SCENE[cut:][: len(BASE_SCENE) // 3])


@settings(max_examples=int(os.environ.get("FUZZ_EXAMPLES", 100)), deadline=None,
          derandomize=not os.environ.get("FUZZ_EXAMPLES"),
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(max_size=200))
def test_arbitrary_text_fails_cleanly(tmp_path, text):
    _check(tmp_path, text)
