"""Summaries read back across subpackages carry a schema: a reader refuses a folder of
another schema (naming it and the fix) and reads one written before the field existed."""

import json

import pytest

from volcaustics.infra.errors import InputError
from volcaustics.reports.animate.read import KIND, load_animation
from volcaustics.reports.core.summaries import SCHEMAS, check_schema


def test_the_current_schema_and_one_without_the_field_are_read():
    check_schema({"schema": SCHEMAS["animation"]}, "animation", "here", "fix")
    check_schema({}, "comparison", "here", "fix")  # written before summaries carried it: version 1


def test_an_animation_of_another_schema_is_refused(tmp_path):
    """Negative control: the same folder with the current schema goes past the check (to the
    media it lacks); with another it is refused for its schema."""
    summary = {"kind": KIND, "metrics": {}, "schema": SCHEMAS["animation"] + 1}
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(InputError, match=f"schema {SCHEMAS['animation'] + 1}"):
        load_animation(str(tmp_path))
    (tmp_path / "summary.json").write_text(json.dumps({**summary, "schema": SCHEMAS["animation"]}))
    with pytest.raises(InputError, match="unreadable"):
        load_animation(str(tmp_path))
