"""What every page of the project shares: its style sheet and script (self-contained:
nothing fetched), number formats, figures and colour bars (``page.html``, the report;
``page.external``, ``compare``'s page and the report's other renderers)."""

from __future__ import annotations

import math
from html import escape

CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;margin:0 auto;padding:12px 20px;max-width:1320px;
     color:#222;font-size:14px;line-height:1.4}
h1{font-size:22px;margin:4px 0} h2{font-size:18px;margin:28px 0 6px;border-bottom:1px solid #ccc}
h3{font-size:15px;margin:14px 0 4px}
table{border-collapse:collapse;margin:6px 0;font-size:13px} td,th{padding:2px 8px;border-bottom:1px solid #e4e4e4;
     text-align:right;vertical-align:top} th{background:#f3f3f3} #overview{font-size:12.5px} #overview td{white-space:nowrap}
#overview td.gate{white-space:normal;min-width:260px} #overview td.gate .verdict{white-space:normal} td.l,th.l{text-align:left}
.fail{background:#fde0dc;color:#8b1a10} .pass{background:#dff3e4;color:#14532d} .none{background:#eee;color:#444}
.verdict{font-weight:600;padding:1px 6px;border-radius:3px;display:inline-block;margin:1px 0;white-space:nowrap}
.banner{font-size:16px;padding:8px 12px;border-radius:4px;margin:8px 0}
.row{display:flex;flex-wrap:wrap;gap:12px;align-items:flex-start}
figure{margin:0} figcaption{font-size:12px;color:#444;max-width:300px}
img.render{image-rendering:pixelated;image-rendering:crisp-edges;display:block;border:1px solid #bbb}
img.animation-video{image-rendering:pixelated;width:768px;max-width:100%;display:block;border:1px solid #bbb}
img.animation-plot{max-width:100%;display:block;margin:8px 0}
img.swap{cursor:pointer} img.chart{display:block;max-width:100%}
.bar{height:12px;width:256px;border:1px solid #999} .ticks{display:flex;justify-content:space-between;width:258px;
     font-size:11px;color:#333}
.note{color:#555;font-size:12px} .missing{display:flex;align-items:center;justify-content:center;
     background:#eee;color:#444;border:1px dashed #999} code{font-size:12px} .warn{color:#8b1a10}
nav a{margin-right:10px} details{margin:4px 0}
"""

SCRIPT = """
document.querySelectorAll('img.swap').forEach(function (img) {
  var own = img.src, other = document.getElementById(img.dataset.other);
  var label = document.getElementById(img.dataset.label), locked = false;
  function show(ref) {
    img.src = ref ? other.src : own;
    if (label) label.textContent = ref ? 'showing: reference (hover off or click to return)'
                                       : 'showing: ' + (img.dataset.name || 'approximation') +
                                         ' (hover or click: reference)';
  }
  img.addEventListener('mouseenter', function () { if (!locked) show(true); });
  img.addEventListener('mouseleave', function () { if (!locked) show(false); });
  img.addEventListener('click', function () { locked = !locked; show(locked); });
});
"""


def verdict(passed: bool | None, text: str) -> str:
    """A pass / FAIL / none mark with ``text`` (escaped)."""
    if passed is None:
        return f"<span class='verdict none'>– {escape(text)}</span>"
    return (f"<span class='verdict {'pass' if passed else 'fail'}'>{'✓ pass' if passed else '✗ FAIL'} "
            f"{escape(text)}</span>")


def num(value: float | None, fmt: str = "{:.3g}", missing: str = "–") -> str:
    if value is None or (isinstance(value, float) and value != value):
        return missing
    return fmt.format(value)


def pct(value: float | None, digits: int = 2) -> str:
    return num(None if value is None else 100.0 * value, "{:.%df}%%" % digits)


BELOW_NOISE = "≤ noise"


def debiased_pct(value: float | None, *, se: float | None = None, low: float | None = None,
                 high: float | None = None, digits: int = 2) -> str:
    """A debiased relative MSE (an error less the noise floors) in %, with its uncertainty
    as given: ``se`` (± SE, in % points) or the 95% interval [``low``, ``high``]. Its true
    value is ≥ 0, so a negative estimate says the error is within the noise: it reads
    "≤ noise" with the estimate and its uncertainty in parentheses (the README's mean image
    on dense_forward printed −2.48%, an error below zero). "–" when unknown."""
    if value is None or not math.isfinite(value):
        return "–"

    def percent(x: float) -> str:
        return f"{100 * x:.{digits}f}%"

    spread = f" ± {100 * se:.{digits}f}" if se is not None and math.isfinite(se) else ""
    bounds = (f" [{percent(low)}, {percent(high)}]"
              if low is not None and high is not None and math.isfinite(low) and math.isfinite(high) else "")
    text = percent(value) + spread + bounds
    return text if value >= 0 else f"{BELOW_NOISE} ({text})"


def figure(uri: str | None, caption: str, *, ident: str = "", cls: str = "render", width: int | None = None,
            extra: str = "") -> str:
    if uri is None:  # e.g. an error map whose metric could not be computed
        return (f"<figure><div class='missing' style='width:{width or 256}px;height:{width or 256}px'>not computed"
                f"</div><figcaption>{caption}</figcaption></figure>")
    attributes = (f" width={width}" if width else "") + (f" id='{ident}'" if ident else "") + extra
    return (f"<figure><img class='{cls}' src='{uri}'{attributes} alt='{escape(caption)}'>"
            f"<figcaption>{caption}</figcaption></figure>")


def colour_bar(scale: dict, css: str) -> str:
    ticks = "".join(f"<span>{escape(label)}</span>" for _, label in scale["ticks"])
    return (f"<div class='bar' style='background:{css}'></div><div class='ticks'>{ticks}</div>"
            f"<div class='note'>{escape(scale['label'])}; grey: not compared (glass)</div>")
