"""The single-scattering model's own error (``metrics.model_term``) as image rows and the
summary's ``model`` section: per colour component, what K scattering orders add to the
reference of the paper's model, against the approximation's error. Present when the
reference was rendered with max_scatter > 1 (its ``<component>_ms`` layers)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from volcaustics.experiment.image_rows import IMAGE_COLUMNS, NAN
from volcaustics.metrics.model_term import interval, model_term
from volcaustics.scenes.formats import COLOUR_LAYERS

if TYPE_CHECKING:
    import numpy as np

    from volcaustics.approx.renderer import Frame
    from volcaustics.reference.cache import ReferenceResult

TERM = "model"  # the rows' ``term``
METRICS = ("energy_share", "relmse_own", "relmse_part", "approx_part")


def has_model(reference: ReferenceResult) -> bool:
    """Whether ``reference`` holds the higher scattering orders."""
    return all(f"{c}_ms" in reference.mean for c in COLOUR_LAYERS)


def model_rows(frames: Sequence[Frame], reference: ReferenceResult, keep: np.ndarray, columns: dict) -> tuple:
    """(rows, summary): one row per (component, metric) with term ``model`` and the
    summary's ``model`` section (None, no rows, without the higher orders)."""
    if not has_model(reference):
        return [], None
    rows: list = []
    numbers: dict[str, dict] = {}
    for component in COLOUR_LAYERS:
        stack = [f.images[component] for f in frames]
        try:
            values = model_term(reference.mean[component], reference.var[component], reference.mean[f"{component}_ms"],
                                reference.var[f"{component}_ms"], stack, keep,
                                reference.total_variance_ratio(f"{component}_ms"),
                                term_groups=reference.groups(f"{component}_ms"),
                                reference_groups=reference.groups(component) if component == "caustic" else None)
        except ValueError as exc:
            numbers[component] = {"note": str(exc)}
            continue
        numbers[component] = {}
        for metric in METRICS:
            value, debiased, se = values[metric]
            low, high = interval(debiased, se) if se == se else (NAN, NAN)
            rows.append({"component": component, "metric": metric, "term": TERM, **IMAGE_COLUMNS, "value": value,
                         "debiased": debiased, "standard_error": se, "ci_low": low, "ci_high": high, **columns})
            numbers[component][metric] = {"value": value, "debiased": debiased, "standard_error": se}
    manifest = reference.manifest
    convergence = manifest.get("convergence") or {}
    needed = {c: (v or {}).get("orders_needed") for c, v in convergence.items()}
    summary = {"max_scatter": manifest.get("settings", {}).get("max_scatter"), "orders_needed": needed,
               "converged": all(v is not None for v in needed.values()), "components": numbers,
               "rule": "order n+1 changes R_ms by a relative MSE (debiased) at most R_ms's noise floor"}
    return rows, summary
