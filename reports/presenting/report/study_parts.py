"""Each study's part of the accuracy report (``reports.studies.registry``: a study's
``ReportInput`` names its ``gather`` here): its output folders, given to ``report OPTION``,
read into its typed result and then into its field of the report's document, before
anything is measured; bad input is a ReportError naming the option and the fix.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

from volcaustics.reports.measuring.results.tables import rows_of
from volcaustics.reports.presenting.page.animations import animation_rows
from volcaustics.reports.presenting.page.external import comparison_images, comparison_row
from volcaustics.reports.presenting.page.frame_check_section import frames_rows
from volcaustics.reports.presenting.page.report_document import FramesSummary, SweepSummary
from volcaustics.reports.presenting.report.sweep_store import ReportError, load_sweep
from volcaustics.reports.studies.animate.animation_read import load_animation
from volcaustics.reports.studies.best.best_search import verdict
from volcaustics.reports.studies.best.frame_check import load_frames
from volcaustics.reports.studies.compare.comparison_read import comparison_folders, load_comparison, parse_named
from volcaustics.reports.studies.study import Gathered
from volcaustics.reports.studies.sweep.best_figures import role_rows
from volcaustics.reports.studies.sweep.suffice import settings_that_suffice
from volcaustics.reports.studies.sweep.variants import best_variants, is_variants_sweep, variant_table
from volcaustics.scenes import resolve_scene

if TYPE_CHECKING:
    from volcaustics.reports.measuring.results.sweep_tables import SweepTables


def gather_sweep(values: Sequence[str], scenes: Sequence[str]) -> Gathered:
    """``--sweep DIR``: the store's consolidated tables (for the figures) and its summary."""
    sweep = load_sweep(values[-1])
    return Gathered(sweep_summary(sweep), tables=sweep)


def gather_animations(values: Sequence[str], scenes: Sequence[str]) -> Gathered:
    """``--animation DIR`` …: each animation's row, its video and plot as media."""
    animations = [load_animation(folder) for folder in values]
    return Gathered(tuple(animation_rows(animations)), media=tuple(dict(a.media) for a in animations))


def gather_comparisons(values: Sequence[str], scenes: Sequence[str]) -> Gathered:
    """``--compare NAME=DIR`` …: each comparison's row (on a scene the report shows) and its images."""
    compared = load_comparisons([parse_named(text, "--compare") for text in values], scenes)
    return Gathered(tuple(row for row, _ in compared),
                    media=tuple(comparison_images(row, views) for row, views in compared))


def gather_frames(values: Sequence[str], scenes: Sequence[str]) -> Gathered:
    """``--frames DIR``: the frame check's rows, verdict and folder."""
    table, manifest = load_frames_check(values[-1])
    return Gathered(FramesSummary(tuple(frames_rows(table) or ()), manifest["verdict"], os.path.abspath(values[-1])))


def load_frames_check(folder: str) -> tuple:
    """A frame check's (table, manifest); ReportError naming the fix."""
    try:
        return load_frames(folder)
    except (OSError, ValueError, KeyError) as exc:
        raise ReportError(f"--frames {folder}: not a readable frame check ({exc}): run `volcaustics frames -o "
                          f"{folder}`") from None


def load_comparisons(pairs: Iterable[tuple[str, str]], names: Iterable[str]) -> list:
    """(row, views) of every comparison ``report --compare NAME=DIR`` names, each of a
    scene the report shows (by content: the scene hash), in the order given."""
    shown = {resolve_scene(name).scene_hash(): name for name in names}
    out: list
    out, seen = [], set()
    for name, folder in pairs:
        for path in comparison_folders(folder, f"--compare {name}="):
            c = load_comparison(path, f"--compare {name}=")
            if c.scene_hash not in shown:
                raise ReportError(f"--compare {name}={path}: compares {c.scene!r} (hash {c.scene_hash[:12]}), "
                                  f"which this report does not show (or shows changed): add it to --scenes, or "
                                  f"rerun compare on the scene as it is now")
            if (name, c.scene_hash) in seen:
                raise ReportError(f"--compare {name}={path}: a second comparison of {name} on {c.scene}: give "
                                  f"each renderer one folder per scene")
            seen.add((name, c.scene_hash))
            row = comparison_row(c, name)
            row["scene"], row["anchor"] = shown[c.scene_hash], f"compare-{len(out)}"
            out.append((row, c.views))
    return out


def sweep_summary(sweep: SweepTables) -> SweepSummary:
    """What the report's summary.json keeps of a sweep store (its figures' paths added when drawn)."""
    suffice = settings_that_suffice(sweep.tables["points"], sweep.varied)
    wanted = suffice[suffice["parameter"].isin(("layers", "iterations", "peak_samples"))] if len(suffice) else suffice
    return SweepSummary(
        folder=os.path.abspath(sweep.folder), varied=tuple(sweep.varied), spec=sweep.spec,
        points=int(len(sweep.tables["points"])), suffice=tuple(rows_of(wanted)),
        # what the sweep's figures plot (one row per point: parameters, errors, frame time); the segment and
        # photon tables they also draw stay in the store (DIR/segments.parquet, DIR/photons.parquet)
        point_rows=tuple(rows_of(sweep.tables["points"])),
        suffice_factor=float(wanted["factor"].iloc[0]) if len(wanted) else None, figures=(),
        variants=_variants_summary(sweep), best=_best_summary(sweep), notes=tuple(getattr(sweep, "notes", [])))


def _best_summary(sweep) -> dict | None:
    """The best-configuration search's rows with a role (paper, adopted, scene best) and
    its verdict (reports/studies/best/best_search.py); None for another sweep."""
    table = sweep.tables.get("best")
    if table is None or not len(table):
        return None
    adopted = next((r["config"] for _, r in table.iterrows() if "adopted" in str(r["role"]).split(", ")), None)
    criterion = str(table["criterion"].iloc[0]) if "criterion" in table else "bias"  # older searches: bias
    return {"rows": rows_of(role_rows(table)), "verdict": verdict(table, adopted, criterion),
            "points": int(len(table))}


def _variants_summary(sweep) -> dict | None:
    """A variants sweep's table per point and, per scene, the paper's point and the best
    variant at no more map reads per segment (reports/studies/sweep/variants.py); else None."""
    if not is_variants_sweep(sweep.varied) or "best" in sweep.tables:  # the best search has its own view
        return None
    table = variant_table(sweep.tables)
    return {"best": rows_of(best_variants(table)), "points": rows_of(table)}
