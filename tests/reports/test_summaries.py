"""Summaries read back across subpackages carry a schema: a reader refuses a folder of
another schema (naming it and the fix) and reads one written before the field existed."""

import json

import pytest

from volcaustics.experiment.summaries import SCHEMAS, check_schema
from volcaustics.infra.errors import InputError
from volcaustics.reports.studies.animate.animation_read import KIND, load_animation


def test_the_current_schema_and_one_without_the_field_are_read():
    check_schema({"schema": SCHEMAS["animation"]}, "animation", "here", "fix")
    check_schema({}, "comparison", "here", "fix")  # written before summaries carried it: version 1


def _animation(**changes) -> dict:
    """An animation summary with every field the report and the gate read."""
    metrics = {"caustic": {"flicker": 0.1, "flicker_se": 0.01}, "combined": {"flicker": 0.05, "flicker_se": 0.01}}
    return {"kind": KIND, "schema": SCHEMAS["animation"], "scene": "refocus", "frames": [0, 2, 4],
            "animation": {"fps": 12}, "seed_modes": ["per-frame"], "chains": 2, "seconds": {"total": 1.0},
            "video": {"web": "refocus.webp"}, "metrics": {"per-frame": metrics}, **changes}


def test_an_animation_of_another_schema_is_refused(tmp_path):
    """Negative control: the same folder with the current schema goes past the check (to the
    media it lacks); with another it is refused for its schema."""
    summary = _animation(schema=SCHEMAS["animation"] + 1)
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(InputError, match=f"schema {SCHEMAS['animation'] + 1}"):
        load_animation(str(tmp_path))
    (tmp_path / "summary.json").write_text(json.dumps({**summary, "schema": SCHEMAS["animation"]}))
    with pytest.raises(InputError, match="unreadable"):
        load_animation(str(tmp_path))


@pytest.mark.parametrize("changes, field", [
    ({"scene": None}, "scene"),
    ({"frames": None}, "frames"),
    ({"animation": {}}, "animation.fps"),
    ({"seed_modes": []}, "seed_modes"),
    ({"metrics": {}}, "metrics.per-frame"),
    ({"metrics": {"per-frame": {}}}, "metrics.per-frame"),
    ({"chains": "2"}, "chains"),
    ({"schema": True}, "schema True"),
])
def test_an_animation_summary_is_checked_against_its_full_shape(tmp_path, changes, field):
    """A summary missing what the report and the gate read once passed the reader and
    failed later with a KeyError (in `report`, after measuring); now it is refused at load,
    naming the field. The complete summary goes past the check (the negative control:
    test above, to the media it lacks)."""
    (tmp_path / "summary.json").write_text(json.dumps(_animation(**changes)))
    with pytest.raises(InputError, match=field.replace(".", r"\.")):
        load_animation(str(tmp_path))
