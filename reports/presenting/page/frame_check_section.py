"""The report's "One frame" section: the frame check's table (``volcaustics frames``,
``reports.studies.best.frame_check``), per scene the paper's configuration against the presets best and beams,
one frame's caustic error and the mean's, without and with OIDN, held-out scenes
marked; and whether best meets the goal."""

from __future__ import annotations

from html import escape
from typing import TYPE_CHECKING

from volcaustics.reports.presenting.page.parts import debiased_pct

if TYPE_CHECKING:
    import pandas as pd

    from volcaustics.reports.presenting.page.report_document import FramesSummary


def _seconds(value) -> str:
    return "" if not value or value != value else f"{value:.2f}"


def frames_rows(table: pd.DataFrame | None) -> list | None:
    """The table as plain rows for summary.json (None without a frame check)."""
    return None if table is None else [{k: (None if v != v else v) for k, v in r.items()}
                                       for r in table.to_dict("records")]


def _ratio(value, fmt: str = "{:.2f}×") -> str:
    """``value`` in ``fmt``; "–" for a missing number (None: frames.json holds NaN as null)."""
    return "–" if value is None or value != value else fmt.format(value)


def _group_label(row) -> str:
    """The scene's group beside its name: held out, a media scene, or nothing (a built-in)."""
    group = row.get("group", "heldout" if row["heldout"] else "builtin")
    return {"heldout": " <i>(held out)</i>", "media": " <i>(medium)</i>", "yours": " <i>(yours)</i>"}.get(group, "")


def frames_section(frames: FramesSummary | None) -> str:
    """HTML of the report's frame check (rows and verdict), "" without one."""
    if frames is None:
        return ""
    v = frames.verdict
    head = ("<tr><th class='l'>scene</th><th class='l'>configuration</th><th class='l'>denoiser</th>"
            "<th>photon_res</th><th>predicted cost vs paper</th><th>measured time vs paper</th>"
            "<th>one frame's relMSE</th><th>vs paper</th>"
            "<th>mean's relMSE, debiased</th><th>vs paper</th><th>OIDN s/frame</th></tr>")
    body = "".join(
        f"<tr><td class='l'>{escape(r['scene'])}{_group_label(r)}</td>"
        f"<td class='l'>{escape(r['config'])}</td><td class='l'>{escape(r['denoise'])}</td>"
        f"<td>{_ratio(r['photon_res'], '{:.0f}')}</td><td>{_ratio(r['cost_ratio'], '{:.3f}×')}</td>"
        f"<td>{_ratio(r.get('time_ratio'))}</td>"
        f"<td>{debiased_pct(r['frame_relmse'], se=r['frame_relmse_se'])}</td>"
        f"<td>{_ratio(r['frame_ratio'])}</td><td>{debiased_pct(r['relmse_debiased'], se=r['relmse_se'])}</td>"
        f"<td>{_ratio(r['relmse_ratio'])}</td><td>{_seconds(r.get('denoise_s'))}</td></tr>"
        for r in frames.rows)
    worst = (f"best's worst one-frame ratio without a denoiser: "
             f"{_ratio(v.get('none_builtin_worst_frame_ratio'))} on the built-ins, "
             f"{_ratio(v.get('none_heldout_worst_frame_ratio'))} on the held-out scenes"
             + (f", {_ratio(v['none_media_worst_frame_ratio'])} in the media scenes"
                if "none_media_worst_frame_ratio" in v else "")
             + f" (goal ≤ {v['goal']:g}× on every scene: <b>{'met' if v['met'] else 'not met'}</b>); with OIDN "
             f"{_ratio(v.get('oidn_builtin_worst_frame_ratio'))} and "
             f"{_ratio(v.get('oidn_heldout_worst_frame_ratio'))}")
    if "beams_none_builtin_worst_frame_ratio" in v:
        worst += (f". beams' worst one-frame ratio without a denoiser: "
                  f"{_ratio(v['beams_none_builtin_worst_frame_ratio'])} on the built-ins, "
                  f"{_ratio(v.get('beams_none_heldout_worst_frame_ratio'))} on the held-out scenes")
    return f"""<h2 id='one-frame'>One frame: the paper's configuration against the presets best and beams</h2>
<p class='note'>What a viewer sees is one frame: its relative MSE less the reference's floor (bias and that frame's
own noise, ± SE over the seeds), beside the seeds' mean's debiased error. best's and beams' photon_res matches the paper
configuration's frame cost on each scene: its predicted time under every weight set of the cost model (the largest
ratio is shown), with the measured frame time beside it; OIDN is shown beside, never inside the cost. Held-out
scenes were seen by no search. {worst}.</p>
<table id='frames-table'>{head}{body}</table>"""
