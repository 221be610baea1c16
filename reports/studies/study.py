"""What a study is, as the CLI and the report see it: its command, and the part of the
accuracy report its output adds (the report's option, the field of the report's
``summary.json`` it fills and the function that reads its folders into that field).

Each study's subpackage declares its studies in its ``__init__`` (``STUDIES``); the
registry (``reports.studies.registry``) finds them. Functions are named by import path
(``"module:function"``) and imported on use, so ``volcaustics --help`` imports no study.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

PARTS = "volcaustics.reports.presenting.report.study_parts"  # the built-in studies' report parts


@dataclass(frozen=True)
class ReportInput:
    """A study's output in the accuracy report: ``report OPTION DIR`` (``repeatable``: one
    option per folder) fills the report's ``summary.json`` field ``field`` with what
    ``gather`` returns (``"module:function"``: ``gather(values, scenes)`` → a
    ``reports.studies.study.Gathered``, InputError naming the option for a bad folder,
    before anything is measured). The page places the built-in studies' sections itself;
    a study's ``section``, when it names one, is drawn after them (a new study's)."""

    option: str
    field: str
    metavar: str
    help: str
    gather: str
    repeatable: bool = False
    path: bool = True   # its value is a folder (NAME=DIR when not)
    section: str | None = None  # "module:function"(its field's value, media) → HTML, drawn after the page's own


@dataclass(frozen=True)
class Study:
    """One study: ``volcaustics NAME`` (``command``: the CLI module, with ``register`` and
    ``run``; its help says what it measures), where ``--help`` lists it (``order``) and its
    part of the report (``report``: None for a study the report does not take)."""

    name: str
    command: str
    order: int
    report: ReportInput | None = None


@dataclass(frozen=True)
class Gathered:
    """A study's outputs read for the report: ``document``, its field's value in the
    report's ``summary.json`` (JSON data: records; the built-in studies' fields, which the
    report's document types, take their types); ``media``, data the page shows but the
    document does not keep (data URIs of its images, per row); ``tables``, what the page
    draws figures from (a sweep's tables)."""

    document: Any
    media: tuple = ()
    tables: Any = None
