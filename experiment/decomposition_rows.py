"""The caustic's error decomposed (``metrics.decomposition``) and its image rows."""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcaustics.experiment.image_rows import IMAGE_COLUMNS, NAN
from volcaustics.metrics.decomposition import decompose_caustic

if TYPE_CHECKING:
    import numpy as np

    from volcaustics.reference.cache import ReferenceResult


def decompose(exact: dict, reference: ReferenceResult, keep: np.ndarray) -> dict:
    return decompose_caustic(exact["batches"], reference.mean["caustic"], keep=keep,
                             reference_var=reference.var["caustic"],
                             reference_ratio=reference.total_variance_ratio("caustic"),
                             reference_groups=reference.groups("caustic"), subsets=exact["subset_batches"])


def decomposition_rows(decomposition: dict, columns: dict) -> list:
    """The decomposition as image rows (component ``caustic``, ``term`` set): per term
    and the total, energy_share, relmse_part, relmse_own with standard errors; the
    noise row's energy_sigma and relmse; the residual's z-scores and verdict."""
    def row(term, metric, value, se=NAN):
        return {"component": "caustic", "metric": metric, "term": term, **IMAGE_COLUMNS, "value": float(value),
                "standard_error": float(se), **columns}

    rows = []
    for r in decomposition["rows"]:
        for metric, value in r.items():
            if metric != "term" and not metric.endswith("_se"):
                rows.append(row(r["term"], metric, value, r.get(f"{metric}_se", NAN)))
    res = decomposition["residual"]
    rows += [row("residual", "energy_z", res["energy_z"]), row("residual", "debiased_relmse", res["debiased_relmse"],
                                                                res["relmse_se"]),
             row("residual", "relmse_z", res["relmse_z"]), row("residual", "within_noise", res["within_noise"])]
    return rows
