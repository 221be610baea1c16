"""Tidy tables and strict JSON: one type per column for Parquet, and the inverse for
code that reads rows (every parameter a column, so a sweep is one
``groupby`` away from a plot)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd


def table(rows: list) -> pd.DataFrame:
    """Rows as a pandas DataFrame with one type per column: integers with gaps (a
    ``step`` that is None on the rows of all steps) as nullable Int64, text as string."""
    frame = pd.DataFrame(rows)
    for column in frame.columns:
        values = [row.get(column) for row in rows if row.get(column) is not None]
        if values and all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in values):
            frame[column] = frame[column].astype("Int64")
        elif values and all(isinstance(v, str) for v in values):
            frame[column] = frame[column].astype("string")
    return frame


def rows_of(frame: pd.DataFrame) -> list:
    """A table's rows as dicts, None for every missing value (NaN, pd.NA): the inverse
    of :func:`table` for code that reads rows."""
    return frame.astype(object).where(frame.notna(), None).to_dict("records")


def plain(value: object) -> Any:
    """``value`` as strict JSON data: numpy scalars and arrays as Python numbers and
    lists, tuples as lists, NaN and ±inf as None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    return value
