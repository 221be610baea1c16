"""``volcaustics compare``: any renderer's images of a scene against the ground truth
(docs/howto/other-renderer.md: ``inputs`` reads and checks the EXRs,
``run`` measures them as the approximation is measured, ``write`` writes the folder,
``read`` reads it back for the report and the gate."""

from volcaustics.reports.studies.study import PARTS, ReportInput, Study

STUDIES = (Study("compare", "volcaustics.reports.cli.compare", order=10, report=ReportInput(
    "--compare", "comparisons", "NAME=DIR",
    "add another renderer that `volcaustics compare SCENE IMAGE.exr -o DIR` measured (DIR: one such folder or a "
    "folder of them, one per scene): a row beside the approximation and its images in each scene it compared "
    "(repeatable)", f"{PARTS}:gather_comparisons", repeatable=True, path=False)),)
