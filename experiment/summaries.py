"""The summaries written to disk, typed: ``ExperimentSummary`` (one experiment's
summary.json, as measured and as stored: read into ``experiment.result.Experiment`` at
the store's boundary), and the ``schema`` version of every summary a command writes and
another reads back (:data:`SCHEMAS`), which their readers check.
"""

from __future__ import annotations

from typing import TypedDict

from volcaustics.infra.errors import InputError

# The version of each summary.json a command writes and another reads back: bumped when a
# field is renamed or its meaning changes, so that a reader refuses a folder it would misread.
# A summary without the field predates it and is version 1 (its fields are those of 1).
SCHEMAS = {"animation": 1, "comparison": 1, "experiment": 1}


class _Measured(TypedDict):
    """The keys every experiment summary has (:class:`ExperimentSummary`; two classes, as
    Python 3.10 has no ``NotRequired``)."""

    kind: str                    # experiment.point_summary.KIND
    schema: int
    scene: str
    scene_hash: str
    optical_depth: float
    description: str
    params: dict                 # ApproxParams.to_dict(), resolved
    seeds: int
    seed_values: list
    reference: dict              # experiment.point_summary.reference_summary
    exact: dict | None           # None: a gate point (scope "gate")
    compared_pixels: int
    images: dict                 # component → metric → {"value", "debiased", …}
    decomposition: dict | None   # {"rows", "residual", "options"}; None: a gate point
    model: dict | None           # the model term; None: a gate or a decomposition point
    paths: dict | None           # None: a decomposition point (scope "decomposition")
    map_reads: dict
    cost: dict
    predicted_frame: dict
    approx_timings_s: dict       # empty, and timed_frames 0: a decomposition point
    timed_frames: int
    timing_method: str
    experiment_seconds: dict     # stage → seconds
    gl: dict
    code_version: str
    versions: dict
    warnings: list
    scene_fields: dict           # dotted path → value of the fields a sweep changed


class ExperimentSummary(_Measured, total=False):
    """One experiment's summary
    (``experiment.point_summary.experiment_summary``): what ``measure -o
    DIR`` writes as summary.json and a result store keeps with each point
    (``reports.measuring.results.store``: with the keys below, which only some have).
    Plain JSON data once stored (NaN as None). Its ``schema`` is ``SCHEMAS["experiment"]``:
    the store counts a point of another schema as missing (measured again)."""

    key: str                     # the store's
    key_document: dict
    files: dict
    summary_sha256: str
    equal_cost: dict | None      # measure: a preset matched to the paper's cost
    outputs: dict                # measure -o DIR: the files written


def of_schema(summary: dict, kind: str) -> bool:
    """Whether ``summary`` is of this code's schema for ``kind`` (no ``schema``: 1)."""
    found = summary.get("schema", 1)
    return type(found) is int and found == SCHEMAS[kind]  # true is not schema 1


def check_schema(summary: dict, kind: str, where: str, fix: str) -> None:
    """InputError naming ``where`` and ``fix`` unless ``summary`` is of this code's
    schema for ``kind``."""
    if not of_schema(summary, kind):
        raise InputError(f"{where}: summary.json is of {kind} schema {summary.get('schema', 1)!r}, this volcaustics "
                         f"reads {SCHEMAS[kind]}: {fix}")
