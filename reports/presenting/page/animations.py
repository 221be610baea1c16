"""The report's "Over time" section: animations that ``volcaustics animate`` measured
(``report --animation DIR``, read by ``reports.studies.animate.animation_read``), each with its embedded
animation, its time-series plot and its flicker numbers per seed mode."""

from __future__ import annotations

import math
from html import escape
from typing import TYPE_CHECKING

from volcaustics.experiment.versions import code_version

if TYPE_CHECKING:
    from volcaustics.reports.studies.animate.animation_read import MeasuredAnimation

SHOWN = ("caustic", "combined")


def animation_rows(loaded: list[MeasuredAnimation]) -> list:
    """What the report's summary.json keeps of each animation (the media stay in its folder)."""
    current = code_version()
    return [{"scene": a.scene, "folder": a.folder, "frames": a.frames, "fps": a.fps, "seed_modes": list(a.seed_modes),
             "chains": a.chains,
             "metrics": {mode: {c: f.to_json() for c, f in parts.items()} for mode, parts in a.metrics.items()},
             "seconds": dict(a.seconds), "video": dict(a.video), "code_version": a.code_version,
             "perceptual_video_metric": a.perceptual_video_metric, "stale": a.code_version != current} for a in loaded]


def _pct(value, digits: int = 2) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{100 * value:.{digits}f}%"


def _table(row: dict) -> str:
    head = ("<tr><th>seed</th><th>component</th><th>flicker ± SE</th><th>systematic</th><th>own noise</th>"
            "<th>relative MSE per frame: mean</th><th>worst</th><th>energy jitter (RMS)</th></tr>")
    body = []
    for mode in row["seed_modes"]:
        for component in SHOWN:
            m = row["metrics"][mode][component]
            jitter = m.get("energy_jitter_rms")
            body.append(f"<tr><td>{escape(mode)}</td><td>{component}</td>"
                        f"<td class='flicker'>{_pct(m.get('flicker'))} ± {_pct(m.get('flicker_se'))}</td>"
                        f"<td>{_pct(m.get('flicker_systematic'))}</td><td>{_pct(m.get('flicker_approx_noise'))}</td>"
                        f"<td>{_pct(m.get('relative_mse_mean'))}</td><td>{_pct(m.get('relative_mse_worst'))}</td>"
                        f"<td>{'–' if jitter is None else f'{jitter:.4f}'}</td></tr>")
    return f"<table class='over-time-table'>{head}{''.join(body)}</table>"


def _cvvdp(rows: list) -> str:
    reasons = {(r.get("perceptual_video_metric") or {}).get("reason") for r in rows}
    named = sorted(reason for reason in reasons if reason is not None)
    return "".join(f"<p class='note cvvdp'>{escape(reason)}</p>" for reason in named)


def over_time_section(rows: list, media: list) -> str:
    """The section (empty without animations); ``media``: per row its data URIs."""
    if not rows:
        return ""
    parts = []
    for row, uris in zip(rows, media):
        s = row["seconds"]
        stale = ("<p class='warn'>Measured with other code (version "
                 f"{escape(str(row['code_version']))}): rerun <code>volcaustics animate</code>.</p>"
                 if row["stale"] else "")
        parts.append(f"""<div class='animation' id='over-time-{escape(row['scene'])}'>
<h3>{escape(row['scene'])}</h3>{stale}
<p class='note'>{len(row['frames'])} frames at {row['fps']:g} fps, {row['chains']} chain(s) per seed mode; per frame
the approximation took {1000 * s['approx_frame_median']:.0f} ms, the reference {s['reference_frame_median']:.1f} s.
Left to right: the approximation ({escape(row['video']['mode'])} seed), the reference, the per-pixel relative MSE of
the combined image. Folder <code>{escape(row['folder'])}</code>.</p>
<img class='animation-video' src='{uris['web']}'
 alt='{escape(row['scene'])}: approximation, reference, error over time'>
<img class='animation-plot' src='{uris['plot']}' alt='{escape(row['scene'])}: errors over time'>
{_table(row)}</div>""")
    return f"""<section id='over-time'><h2>Over time</h2>
<p class='note'>The paper retraces every frame (§6). Flicker of a frame pair: Σ(ΔA − ΔR)²/ΣR² with ΔX the change
from the frame before, less the references' noise (metrics/temporal.py); its mean over the pairs ± SE. Systematic: what
remains with the approximation's own frame-to-frame noise (the chains' spread) removed. A fixed seed draws the same
photons every frame; a per-frame seed draws new ones.</p>{_cvvdp(rows)}
{''.join(parts)}</section>"""
