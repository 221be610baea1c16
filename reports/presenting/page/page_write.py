"""Writing the accuracy report: ``index.html`` drawn from the summary's strict-JSON data
with each scene's pictures, and, last, ``summary.json``; a sweep's figures as files."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from tqdm import tqdm

from volcaustics.experiment.versions import code_version
from volcaustics.infra.storage import (
    atomic_write_text,
    atomic_write_texts,
    cache_dir,
    cache_path,
    note_not_cached,
    read_json_object,
)
from volcaustics.reports.measuring.results.tables import plain
from volcaustics.reports.presenting.figures.plotting import remove_stale_figures
from volcaustics.reports.presenting.page import charts
from volcaustics.reports.presenting.page.data_uris import component_images, data_uri, render_uri
from volcaustics.reports.presenting.page.html import render_page
from volcaustics.reports.presenting.page.report_document import ReportDocument
from volcaustics.reports.presenting.page.report_summary import OUTPUT_FILES
from volcaustics.reports.studies.sweep.best_figures import draw_best
from volcaustics.reports.studies.sweep.sweep_figures import draw_figures
from volcaustics.reports.studies.sweep.variants import draw_variants, is_variants_sweep, variant_table

if TYPE_CHECKING:
    from volcaustics.reports.measuring.results.scene_result import SceneResult
    from volcaustics.reports.measuring.results.sweep_tables import SweepTables
    from volcaustics.reports.presenting.page.report_document import ScenePage


def write_report(out_dir: str, results: list, document: ReportDocument, sweep: SweepTables | None = None, *,
                 progress: bool = False, started: float | None = None,
                 media: Mapping[str, Sequence[dict]] | None = None) -> ReportDocument:
    """Draw ``index.html`` from ``document`` (and each scene's views), write it and,
    last, ``summary.json``; the sweep's figures also as files under ``figures/`` (an
    earlier run's figures removed). The page is drawn from the document read back from
    the strict-JSON data that ``summary.json`` holds (NaN as null), and that document is
    returned. ``started``: the run's ``time.perf_counter()`` at its start, for the total;
    ``media``: per field of the document a study filled, per row its data URIs
    (``animations``: page.animations; ``comparisons``: page.external)."""
    t0 = time.perf_counter()
    os.makedirs(out_dir, exist_ok=True)
    sweep_figures, paths = {}, []
    figures_dir = os.path.join(out_dir, "figures")
    if sweep is not None:
        paths = draw_figures(sweep.tables, figures_dir, varied=sweep.varied)
        if is_variants_sweep(sweep.varied) and "best" not in sweep.tables:  # a variants sweep: its Pareto figures
            paths += draw_variants(variant_table(sweep.tables), figures_dir)
        if "best" in sweep.tables:  # the best-configuration search: paper, adopted and each scene's best
            paths += draw_best(sweep.tables["best"], figures_dir)
    remove_stale_figures(figures_dir, keep=paths)
    if document.sweep is not None:
        for path in paths:
            if path.endswith(".png"):
                with open(path, "rb") as fh:
                    sweep_figures[os.path.splitext(os.path.basename(path))[0]] = data_uri(fh.read())
        figures = tuple(os.path.relpath(p, out_dir) for p in paths)
        document = dataclasses.replace(document, sweep=dataclasses.replace(document.sweep, figures=figures))
    shown = ReportDocument.from_json(plain(document.to_json()))
    images = {page.scene: cached_scene_images(result, page)
              for result, page in tqdm(list(zip(results, shown.scenes)), desc="page", unit="scene",
                                       disable=not progress)}
    html = render_page(shown, images, sweep_figures, media or {})
    seconds = {**shown.seconds, "page": time.perf_counter() - t0}
    if started is not None:
        seconds["total"] = time.perf_counter() - started
    stored = plain(dataclasses.replace(shown, seconds=seconds).to_json())
    # one unit: an interrupted run never leaves a page beside another run's summary
    html_path, doc_path = (os.path.join(out_dir, name) for name in OUTPUT_FILES)
    atomic_write_texts({html_path: html, doc_path: json.dumps(stored, indent=1, allow_nan=False)})
    return ReportDocument.from_json(stored)


# the code a scene's pictures come from: with the stored result's key, their cache key
PAGE_FOLDERS = ("reports/presenting/page", "reports/presenting/figures", "infra", "scenes")


def cached_scene_images(result: SceneResult, page: ScenePage) -> dict:
    """:func:`scene_images`, from the cache when this code drew them for this stored result
    (its key and its summary) before: a warm report draws no picture. A cache that cannot
    be written is noted."""
    stored = result.experiment.summary_sha256  # a point measured again draws anew
    key = hashlib.sha256(json.dumps([result.key, stored, code_version(PAGE_FOLDERS)]).encode()).hexdigest()[:24]
    try:
        return read_json_object(cache_path("page-images", key + ".json"))
    except (OSError, ValueError):  # not drawn yet, or damaged: drawn again
        pass
    images = scene_images(result, page)
    try:
        atomic_write_text(os.path.join(cache_dir("page-images"), key + ".json"), json.dumps(images))
    except OSError as exc:
        note_not_cached(exc, "the report's pictures")
    return images


def scene_images(result: SceneResult, page: ScenePage) -> dict:
    """Data URIs of one scene: renders at the page's exposures, error maps on the fixed
    scales, charts."""
    v = result.views
    out = component_images(v, page.exposure, "approx")
    out["exact_steps"] = render_uri(v["exact_steps"], page.exposure["caustic"])
    out["chart.hit_classes"] = data_uri(charts.hit_classes_chart(page.hit_classes))
    out["chart.power_budget"] = data_uri(charts.power_budget_chart(list(page.power_budget)))
    out["chart.decomposition"] = data_uri(charts.decomposition_chart(page.decomposition))
    out["chart.pass_times"] = data_uri(charts.pass_times_chart(page.timing))
    return out
