"""The settings that suffice: per scene and varied parameter, the smallest value whose
error is within a factor of the best (``suffice.csv``, the console, the report)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from volcaustics.approx.params import PARAMS

# the parameters a sweep figure or the settings that suffice take as a numeric axis
NUMERIC = tuple(p.name for p in PARAMS if p.kind in (int, float) and p.name != "seed")
SUFFICE_FACTOR = 1.1
CRITERIA = {"caustic_relmse_debiased": "caustic relative MSE, debiased (%)",
            "intersection_relmse_own": "intersection error Σ(E_k − A)²/ΣR² (%)"}


def at_best(points, varied, x):
    """The points with every varied numeric parameter but ``x`` at its largest value
    (per scene), and a note saying so."""
    others = [v for v in varied if v != x and v in NUMERIC]
    keep = np.ones(len(points), bool)
    for name in others:
        largest = points.groupby("scene")[name].transform("max")
        keep &= (points[name] == largest).to_numpy(dtype=bool, na_value=False)  # nullable Int64 in pandas 2.1
    note = ", ".join(f"{n} at its largest" for n in others)
    return points[keep], note


def settings_that_suffice(points, varied, factor: float = SUFFICE_FACTOR):
    """Per scene, layer strategy, varied numeric parameter and criterion (CRITERIA:
    the caustic's debiased relative MSE, the intersection term's own relative MSE): the
    smallest value within ``factor`` × the best over that parameter (the other varied
    parameters at their largest), with that error and its frame time."""
    rows = []
    for x in (v for v in varied if v in NUMERIC):
        chosen, _ = at_best(points, varied, x)
        for (scene, strategy), group in chosen.groupby(["scene", "layer_strategy"]):
            for criterion in CRITERIA:
                errors = group[criterion].to_numpy(float)
                if not np.isfinite(errors).any():
                    continue
                best = np.nanmin(errors)
                ok = group[errors <= best + (factor - 1.0) * abs(best) + 1e-12].sort_values(x)
                first = ok.iloc[0]
                rows.append({"scene": scene, "layer_strategy": strategy, "parameter": x, "criterion": criterion,
                             "suffices": first[x], "error": first[criterion], "best": best,
                             "largest": group[x].max(), "frame_time_s": first["frame_time_s"],
                             "map_reads_per_frame": first.get("map_reads_per_frame", np.nan), "factor": factor})
    return pd.DataFrame(rows)
