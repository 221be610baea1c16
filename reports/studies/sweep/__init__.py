"""Sweeps: a grid over the approximation's parameters measured through the runner into a
resumable store, its figures, the settings that suffice, the variants view and the
density sweep's reading of the model term."""

from volcaustics.reports.studies.study import PARTS, ReportInput, Study

STUDIES = (Study("sweep", "volcaustics.reports.cli.sweep", order=30, report=ReportInput(
    "--sweep", "sweep", "DIR", "add a sweep store's figures and settings that suffice", f"{PARTS}:gather_sweep")),)
