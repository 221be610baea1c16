"""A sweep store's consolidated tables, as ``reports.presenting.report`` hands them to
``reports.presenting.page``."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class SweepTables:
    """A sweep store's consolidated tables and the parameters it varied."""

    folder: str
    tables: dict             # "segments", "photons", "images", "points" → DataFrame
    varied: list
    spec: dict
    notes: list = field(default_factory=list)  # what differs from this code (shown on the page)
