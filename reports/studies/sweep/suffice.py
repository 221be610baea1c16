"""The settings that suffice: per scene and varied parameter, the smallest value whose
error is within a factor of the best (``suffice.csv``, the console, the report)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import pandas as pd

from volcaustics.approx.params import PARAMS
from volcaustics.scenes.fields import is_scene_field

# the parameters a sweep figure or the settings that suffice take as a numeric axis
NUMERIC = tuple(p.name for p in PARAMS if p.kind in (int, float) and p.name != "seed")
# the choices that make a variant of the method (layer_strategy, search, start_rule, ...):
# the settings that suffice are found per variant, never across them
VARIANT_CHOICES = tuple(p.name for p in PARAMS if p.choices)
SUFFICE_FACTOR = 1.1
CRITERIA = {"caustic_relmse_debiased": "caustic relative MSE, debiased (%)",
            "intersection_relmse_own": "intersection error Σ(E_k − A)²/ΣR² (%)"}


def variant_keys(points: pd.DataFrame) -> list:
    """The columns a sweep's points are grouped by: the scene, each variant choice and
    each scene field the sweep changed (another medium is another scene)."""
    return ["scene", *(c for c in VARIANT_CHOICES if c in points), *field_keys(points)]


def field_keys(points: pd.DataFrame) -> list:
    """The scene-field columns (dotted paths, ``scenes.fields``) of a points table."""
    return [c for c in points.columns if is_scene_field(str(c))]


def at_best(points: pd.DataFrame, varied: Iterable[str], x: str) -> tuple[pd.DataFrame, str]:
    """The points with every varied numeric parameter but ``x`` at its largest value
    (per scene and variant: a grid of one search need not vary another's knobs), and a
    note saying so."""
    others = [v for v in varied if v != x and v in NUMERIC]
    keep = np.ones(len(points), bool)
    for name in others:
        largest = points.groupby(variant_keys(points))[name].transform("max")
        keep &= (points[name] == largest).to_numpy(dtype=bool, na_value=False)  # nullable Int64 in pandas 2.1
    note = ", ".join(f"{n} at its largest" for n in others)
    return points[keep], note


def settings_that_suffice(points: pd.DataFrame, varied: Sequence[str], factor: float = SUFFICE_FACTOR) -> pd.DataFrame:
    """Per scene, variant (VARIANT_CHOICES: layer strategy, search, start rule), varied
    numeric parameter and criterion (CRITERIA:
    the caustic's debiased relative MSE, the intersection term's own relative MSE): the
    smallest value within ``factor`` × the best over that parameter (the other varied
    parameters at their largest), with that error and its frame time."""
    rows = []
    for x in (v for v in varied if v in NUMERIC):
        chosen, _ = at_best(points, varied, x)
        keys = variant_keys(chosen)
        for values, group in chosen.groupby(keys):
            if group[x].nunique() < 2:  # not varied for this variant
                continue
            variant = dict(zip(keys, values))
            for criterion in CRITERIA:
                errors = group[criterion].to_numpy(float)
                if not np.isfinite(errors).any():
                    continue
                best = np.nanmin(errors)
                ok = group[errors <= best + (factor - 1.0) * abs(best) + 1e-12].sort_values(x)
                first = ok.iloc[0]
                rows.append({**variant, "parameter": x, "criterion": criterion,
                             "suffices": first[x], "error": first[criterion], "best": best,
                             "largest": group[x].max(), "frame_time_s": first["frame_time_s"],
                             "map_reads_per_frame": first.get("map_reads_per_frame", np.nan), "factor": factor})
    return pd.DataFrame(rows)
