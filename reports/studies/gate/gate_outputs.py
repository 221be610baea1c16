"""What the gate writes and prints: the console table, JUnit XML, the failure images
and, as one set, the accepted baseline, the JUnit file and ``gate.json`` (last)."""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from volcaustics.infra.imageio import write_png
from volcaustics.infra.storage import atomic_write_texts
from volcaustics.metrics.image import reference_exposure
from volcaustics.reports.measuring.results.tables import plain

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reports.studies.gate.budgets import Check


@dataclass
class GateResult:
    """A gate run: its ``checks`` (``budgets.Check``), exit code, seconds, the baseline
    it compared with and the one it wrote, and how many points it measured or found
    in the store."""

    checks: list
    exit_code: int
    seconds: float
    baseline: str | None
    updated_baseline: str | None
    measured: int = 0          # points measured in this run
    from_store: int = 0        # points the result store already held


VERDICT = "gate.json"      # in --out; written last, with the baseline and the JUnit file


def failure_images(out_dir: str, scene: str, check: Check, views: dict) -> dict:
    """The caustic as the approximation and the reference see it, and |A − R|, at the
    reference's exposure (PNG) — what a reader of the failure looks at first.
    ``views``: the point's views (``experiment.point_summary.VIEWS``)."""
    a, r = np.asarray(views["approx.caustic"]), np.asarray(views["reference.caustic"])
    try:
        exposure = reference_exposure(r)
    except ValueError:
        exposure = 1.0
    folder = os.path.join(out_dir, "failures", scene)
    paths = {}
    for label, image in (("approx", a), ("reference", r), ("error", np.abs(a - r))):
        path = os.path.join(folder, f"{check.name.replace('.', '_')}_{label}.png")
        write_png(path, image, exposure=exposure)  # this run's, never an earlier run's
        paths[label] = os.path.abspath(path)
    return paths


def write_outputs(out_dir: str, result: GateResult, params: ApproxParams, seeds: int, budgets: dict, *,
                  baseline: str | None, junit: str | None) -> None:
    """The new baseline (when accepted), the JUnit file and, last, gate.json as one set
    (``infra.storage.atomic_set``): an interrupted gate never leaves a new baseline
    without its verdict."""
    doc = {"passed": result.exit_code == 0, "exit_code": result.exit_code, "seconds": result.seconds,
           "budgets": budgets["path"], "params": params.to_dict(), "seeds": seeds, "baseline": result.baseline,
           "updated_baseline": result.updated_baseline,
           "points": {"measured": result.measured, "from_store": result.from_store},
           "checks": [dataclasses.asdict(c) for c in sorted(result.checks, key=lambda c: (c.passed, c.scene, c.name))]}
    texts = {}
    if baseline is not None:
        texts[result.updated_baseline] = baseline
    if junit:
        texts[junit] = junit_xml(result.checks, result.seconds)
    texts[os.path.join(out_dir, VERDICT)] = json.dumps(plain(doc), indent=1, allow_nan=False)
    atomic_write_texts(texts)


def console_table(checks: list) -> str:
    """Failures first, then passes: scene, check, value, limit, verdict."""
    lines = [f"{'verdict':8} {'scene':12} {'check':30} {'value':>12}  limit"]
    for c in sorted(checks, key=lambda c: (c.passed, c.scene, c.name)):
        value = f"{100 * c.value:+.2f}%" if c.name.startswith("regression") else f"{c.value:.4g}"
        lines.append(f"{'pass' if c.passed else 'FAIL':8} {c.scene:12} {c.name:30} {value:>12}  {c.limit}"
                     + (f"   {c.message}" if c.message and (not c.passed or c.name.startswith('regression')) else ""))
    return "\n".join(lines)


def junit_xml(checks: list, seconds: float) -> str:
    """JUnit XML (the schema Jenkins, GitLab and GitHub reporters read): one testsuite,
    one testcase per scene × check, <failure> with values, limits and image paths."""
    failures = sum(not c.passed for c in checks)
    cases = []
    for c in checks:
        body = ""
        if not c.passed:
            text = c.message + "".join(f"\n{label}: {path}" for label, path in c.images.items())
            body = f"<failure message={quoteattr(c.message)} type=\"budget\">{escape(text)}</failure>"
        cases.append(f"  <testcase classname={quoteattr('volcaustics.gate.' + c.scene)} name={quoteattr(c.name)} "
                     f"time=\"0\">{body}</testcase>")
    return ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            f"<testsuites tests=\"{len(checks)}\" failures=\"{failures}\">\n"
            f"<testsuite name=\"volcaustics gate\" tests=\"{len(checks)}\" failures=\"{failures}\" errors=\"0\" "
            f"skipped=\"0\" time=\"{seconds:.3f}\">\n" + "\n".join(cases) + "\n</testsuite>\n</testsuites>\n")
