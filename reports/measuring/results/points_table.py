"""A store's points table: one row of headline numbers per point, read from its summary
(:func:`point_row`), and the columns it holds besides the parameters (:data:`POINT_COLUMNS`:
the schema ``report --sweep`` checks a store against). ``Store.tables`` writes it."""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcaustics.approx.cost import FRAGMENT_PASSES, TIMED_PASSES
from volcaustics.metrics.decomposition import TERMS
from volcaustics.scenes.fields import field_columns

if TYPE_CHECKING:
    from volcaustics.experiment.summaries import ExperimentSummary

# What a store's points table holds besides the parameters (point_row writes exactly these):
# its schema, which ``report --sweep`` checks a store against.
POINT_COLUMNS = ("point", "scene", "scene_hash", "seeds", "reference_key", "code_version", "frame_time_s",
                 "trace_time_s", "splat_time_s", "map_reads_per_frame", "map_reads_per_segment",
                 "emission_reads_per_frame", "splats_per_frame", "frame_cost", "photons_per_frame",
                 "segments_per_frame", *(f"fragments_{name}" for name in FRAGMENT_PASSES),
                 *(f"{name}_time_s" for name in TIMED_PASSES),
                 *(f"{name}_{metric}" for name in ("caustic", "combined")
                   for metric in ("relmse_debiased", "relmse_se", "frame_relmse", "frame_relmse_se", "energy_ratio",
                                  "hdr_flip")),
                 *(f"share_{term}" for term in TERMS),
                 "share_intersection_se", "intersection_relmse_part", "intersection_relmse_part_se",
                 "intersection_relmse_own", "residual_within_noise", "optical_depth",
                 *(f"model_{name}_{metric}" for name in ("caustic", "combined")
                   for metric in ("relmse_own", "relmse_own_se", "energy_share")))


def point_row(key: str, summary: ExperimentSummary) -> dict:
    """The headline numbers of one point: parameters, frame time, errors (POINT_COLUMNS)."""
    images = summary.get("images", {})
    caustic, combined = images.get("caustic", {}), images.get("combined", {})
    decomposition = {r["term"]: r for r in (summary.get("decomposition") or {}).get("rows", [])}
    timings = summary.get("approx_timings_s", {})
    row = {"point": key, "scene": summary["scene"], "scene_hash": summary["scene_hash"],
           "optical_depth": summary.get("optical_depth"), **summary["params"],
           **field_columns(summary.get("scene_fields")),
           "seeds": summary["seeds"], "reference_key": summary["reference"]["key"],
           "code_version": summary["code_version"], "frame_time_s": timings.get("frame_wall"),
           "trace_time_s": timings.get("trace"), "splat_time_s": timings.get("splat"),
           "map_reads_per_frame": summary.get("map_reads", {}).get("per_frame"),
           "map_reads_per_segment": summary.get("map_reads", {}).get("per_segment"),
           "emission_reads_per_frame": summary.get("cost", {}).get("emission_reads"),
           "splats_per_frame": summary.get("cost", {}).get("splats"),
           "frame_cost": summary.get("cost", {}).get("total"),
           "photons_per_frame": summary.get("cost", {}).get("photons"),
           "segments_per_frame": summary.get("cost", {}).get("segments"),
           **{f"fragments_{name}": summary.get("cost", {}).get(f"fragments_{name}") for name in FRAGMENT_PASSES},
           **{f"{name}_time_s": timings.get(name) for name in TIMED_PASSES}}
    for name, metrics in (("caustic", caustic), ("combined", combined)):
        relmse = metrics.get("relative_mse", {})
        row[f"{name}_relmse_debiased"] = relmse.get("debiased")
        row[f"{name}_relmse_se"] = relmse.get("standard_error")
        frame = metrics.get("frame_relative_mse", {})  # one frame's error (metrics.frame), beside the mean's
        row[f"{name}_frame_relmse"] = frame.get("debiased")
        row[f"{name}_frame_relmse_se"] = frame.get("standard_error")
        row[f"{name}_energy_ratio"] = metrics.get("energy_ratio", {}).get("value")
        row[f"{name}_hdr_flip"] = metrics.get("hdr_flip", {}).get("value")
    for term in TERMS:
        row[f"share_{term}"] = decomposition.get(term, {}).get("energy_share")
    # the intersection term's parts of the caustic error, with standard errors over seeds
    intersection = decomposition.get("intersection", {})
    row["share_intersection_se"] = intersection.get("energy_share_se")
    row["intersection_relmse_part"] = intersection.get("relmse_part")
    row["intersection_relmse_part_se"] = intersection.get("relmse_part_se")
    # the intersection estimate's own error: Σ(E_k − A)² / Σ R², what layers and iterations change
    row["intersection_relmse_own"] = decomposition.get("intersection", {}).get("relmse_own")
    row["residual_within_noise"] = (summary.get("decomposition") or {}).get("residual", {}).get("within_noise")
    # the single-scattering model's own error against K orders (none: the reference has one)
    model = (summary.get("model") or {}).get("components", {})
    for name in ("caustic", "combined"):
        own = model.get(name, {}).get("relmse_own", {})
        row[f"model_{name}_relmse_own"] = own.get("debiased")
        row[f"model_{name}_relmse_own_se"] = own.get("standard_error")
        row[f"model_{name}_energy_share"] = model.get(name, {}).get("energy_share", {}).get("value")
    return {k: (float("nan") if v is None else v) for k, v in row.items()}
