"""``volcaustics animate``: a scene's ``[animation]`` measured over time (docs/over-time.md):
``settings`` (the reference budget, size, seeds), ``run`` (frames
through one Renderer and the reference cache, resumable), ``metrics`` (per-frame and
temporal tables), ``media`` (the side-by-side video and the plot), ``write`` (the set)."""

from volcaustics.reports.studies.study import PARTS, ReportInput, Study

STUDIES = (Study("animate", "volcaustics.reports.cli.animate", order=20, report=ReportInput(
    "--animation", "animations", "DIR",
    "add an animation that `volcaustics animate SCENE -o DIR` measured: the 'Over time' section (repeatable)",
    f"{PARTS}:gather_animations", repeatable=True)),)
