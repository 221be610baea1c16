"""The best-configuration search (``sweep --best``) and the one-frame check of the paper's
configuration against ``--preset best`` (``volcaustics frames``)."""

from volcaustics.reports.studies.study import PARTS, ReportInput, Study

STUDIES = (Study("frames", "volcaustics.reports.cli.frames", order=40, report=ReportInput(
    "--frames", "frames", "DIR",
    "add the frame check `volcaustics frames -o DIR` measured: the 'One frame' section (the paper's configuration "
    "against --preset best, without and with OIDN)", f"{PARTS}:gather_frames")),)
