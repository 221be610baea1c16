"""The registry of studies: every ``Study`` the subpackages of ``reports.studies`` declare
(``STUDIES`` in their ``__init__``), in ``--help`` order. The CLI registers their commands
from here and the report takes their outputs by the options declared here, so a new study
is a new subpackage (its ``__init__`` naming its command and its report part).
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from collections.abc import Callable
from typing import Any

import volcaustics.reports.studies as studies_package
from volcaustics.reports.studies.study import Study


@functools.cache
def studies() -> tuple[Study, ...]:
    """Every declared study, by ``order``; ValueError for two of one name."""
    found: list[Study] = []
    for info in pkgutil.iter_modules(studies_package.__path__):
        if info.ispkg:
            module = importlib.import_module(f"{studies_package.__name__}.{info.name}")
            found.extend(getattr(module, "STUDIES", ()))
    for what, values in (("studies", [s.name for s in found]),
                         ("report options", [s.report.option for s in found if s.report]),
                         ("report fields", [s.report.field for s in found if s.report])):
        twice = sorted({v for v in values if values.count(v) > 1})
        if twice:
            raise ValueError(f"{what} declared twice: {', '.join(twice)}")
    return tuple(sorted(found, key=lambda s: (s.order, s.name)))


def reported() -> tuple[Study, ...]:
    """The studies whose output the accuracy report takes."""
    return tuple(s for s in studies() if s.report is not None)


def resolve(path: str) -> Callable[..., Any]:
    """The function ``"module:function"`` names, imported now."""
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)
