"""A debiased relative MSE (an error less the noise floors) is ≥ 0 in truth: a negative
estimate is noise and reads "≤ noise" with the estimate and its uncertainty, in the report
and on the console (the frame check's dense_forward row printed a mean-image error of −2.48%)."""

from __future__ import annotations

import pandas as pd

from volcaustics.reports.cli.common import debiased
from volcaustics.reports.presenting.page.frame_check_section import frames_rows, frames_section
from volcaustics.reports.presenting.page.parts import BELOW_NOISE, debiased_pct
from volcaustics.reports.presenting.page.report_document import FramesSummary
from volcaustics.reports.studies.best.frame_check import verdict, with_ratios


def test_a_negative_estimate_reads_below_noise_with_its_uncertainty():
    assert debiased_pct(-0.0248, se=0.011) == "≤ noise (-2.48% ± 1.10)"
    assert debiased_pct(-0.0235, low=-0.0902, high=0.032) == "≤ noise (-2.35% [-9.02%, 3.20%])"
    assert debiased_pct(0.0318, se=0.0052) == "3.18% ± 0.52"  # a positive one as before
    assert debiased_pct(0.0, low=-0.01, high=0.01) == "0.00% [-1.00%, 1.00%]"
    assert debiased_pct(None) == "–" and debiased_pct(float("nan"), se=0.1) == "–"
    assert debiased(-0.0248, se=0.011).strip() == "≤ noise (-2.48% ± 1.10)" and debiased(None).strip() == "n/a"


def _row(scene, config, frame, mean):
    return {"scene": scene, "heldout": True, "config": config, "denoise": "none", "photon_res": 256,
            "frame_cost": 100.0, "frame_relmse": frame, "frame_relmse_se": 0.17, "relmse_debiased": mean,
            "relmse_se": 0.011, "denoise_s": None}


def test_the_frame_checks_section_prints_a_negative_mean_as_below_noise():
    """The README's table is the frame check's: dense_forward's beams mean at −2.48%."""
    table = with_ratios(pd.DataFrame([_row("dense_forward", "paper", 0.8584, 0.8538),
                                      _row("dense_forward", "best", 0.7555, 0.1514),
                                      _row("dense_forward", "beams", 0.5375, -0.0248)]))
    html = frames_section(FramesSummary(tuple(frames_rows(table)), verdict(table), "frames"))
    assert f"<td>{BELOW_NOISE} (-2.48% ± 1.10)</td>" in html
    assert "<td>-2.48%" not in html and "<td>15.14% ± 1.10</td>" in html
