"""`volcaustics gate`: fail when the approximation gets worse — budgets per scene and a
regression test against the last accepted results (the baseline).

Budgets (TOML; ``reports/budgets.toml`` is the default for the built-ins)::

    preset = "quick"            # the approximation's parameters (``--set`` overrides)
    seeds = 4                   # frames per scene: seeds 0 … seeds − 1
    [scene.bunny]
    caustic.relmse_max = 0.30         # debiased relative MSE (metrics.noise.seed_relative_mse)
    caustic.energy_ratio = [0.3, 0.5] # Σ approx / Σ reference, averaged over RGB
    caustic.hdr_flip_max = 0.95       # mean HDR-FLIP over frames
    combined.relmse_max = 0.02
    segments.missed_step2_max = 0.05  # step-2 segments missed (inside glass or in the medium)
    segments.dt_p90_step2_max = 0.006 # |Δt| p90 of step-2 true hits, m

A budget tighter than the measurement can resolve — a relative-MSE limit below the
reference's floor plus 3 standard errors, an energy band narrower than 3 σ of the
reference's total — is refused (exit 2), naming it.

Regression: per scene, each frame's caustic relative MSE against the baseline's
(``--baseline DIR``, written by ``--update-baseline`` with the reference keys it was
measured against). Same seeds: a paired one-sided t-test (an unchanged approximation
gives identical frames: no false alarm at all); other seeds: Welch's. A regression is
an increase significant at ``ALPHA``; the gate states the smallest relative increase
it detects with 95% power at its seed count.

Exit codes (DESIGN.md): 0 pass, 1 a budget exceeded or a regression, 2 bad input or
missing data — a missing reference or baseline entry, a NaN metric, a scene that does
not exist — never a pass.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, field

ALPHA = 0.01            # one-sided false-alarm rate of the regression test
POWER = 0.95            # for the stated detectable increase
RESOLVE_SIGMAS = 3.0    # a budget must lie this many standard errors beyond the noise
COMPONENT_KEYS = ("relmse_max", "energy_ratio", "hdr_flip_max")
SEGMENT_KEYS = ("missed_step2_max", "dt_p90_step2_max")
TOP_KEYS = ("preset", "seeds", "scene", "reference")
VERDICT = "gate.json"      # in --out; written last, with the baseline and the JUnit file
BASELINE = "baseline.json"  # in --baseline


class GateError(ValueError):
    """Bad budgets, a missing reference or baseline, a NaN metric: exit 2."""


@dataclass
class Check:
    scene: str
    name: str        # e.g. "caustic.relmse_max", "regression.caustic_relmse"
    value: float
    limit: str       # the limit as text ("≤ 0.30", "[0.3, 0.5]", "p < 0.01")
    passed: bool
    message: str = ""
    images: dict = field(default_factory=dict)   # label → path of the images written for a failure
    detail: dict = field(default_factory=dict)   # e.g. p-value, detectable increase


# --- budgets -----------------------------------------------------------------------

def default_budgets_path() -> str:
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "budgets.toml")


def load_budgets(path: str) -> dict:
    """{"preset", "seeds", "scenes": {name: {check: limit}}}, validated."""
    from volcaustics.reports.core.tomlfile import load_toml

    doc = load_toml(path, keys=TOP_KEYS, error=GateError, what="budgets")
    seeds = doc.get("seeds", 4)
    if isinstance(seeds, bool) or not isinstance(seeds, int) or not 2 <= seeds <= 256:
        raise GateError(f"{path}: seeds = {seeds!r}: expected an integer in [2, 256] (the regression test needs 2)")
    preset = doc.get("preset", "quick")
    if preset not in ("quick", "paper"):
        raise GateError(f"{path}: preset = {preset!r}: expected \"quick\" or \"paper\"")
    scenes = doc.get("scene")
    if not isinstance(scenes, dict) or not scenes:
        raise GateError(f"{path}: no [scene.NAME] table: nothing to gate")
    out = {}
    for name, table in scenes.items():
        if not isinstance(table, dict) or not table:
            raise GateError(f"{path}: scene.{name} = {table!r}: expected a table of budgets")
        checks = {}
        for group, values in table.items():
            if not isinstance(values, dict):
                raise GateError(f"{path}: scene.{name}.{group}: expected a table of limits")
            allowed = SEGMENT_KEYS if group == "segments" else COMPONENT_KEYS
            if group not in ("segments", "caustic", "fog", "direct", "combined"):
                raise GateError(f"{path}: scene.{name}.{group}: expected caustic, fog, direct, combined or segments")
            for key, limit in values.items():
                where = f"{path}: scene.{name}.{group}.{key}"
                if key not in allowed:
                    raise GateError(f"{where}: unknown; expected {', '.join(allowed)}")
                if key == "energy_ratio":
                    if (not isinstance(limit, list) or len(limit) != 2
                            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in limit)
                            or not 0 <= limit[0] < limit[1]):
                        raise GateError(f"{where} = {limit!r}: expected [low, high] with 0 ≤ low < high")
                elif isinstance(limit, bool) or not isinstance(limit, (int, float)) or not limit > 0 \
                        or not math.isfinite(limit):
                    raise GateError(f"{where} = {limit!r}: expected a positive number")
                checks[f"{group}.{key}"] = limit
        out[name] = checks
    from volcaustics.reports.sweep.run import REFERENCE_KEYS, SweepError, reference_settings

    reference = doc.get("reference", {})
    if not isinstance(reference, dict) or any(k not in REFERENCE_KEYS for k in reference):
        raise GateError(f"{path}: reference = {reference!r}: expected a table of {', '.join(REFERENCE_KEYS)}")
    try:
        settings = reference_settings(reference)
    except SweepError as exc:
        raise GateError(f"{path}: {exc}") from None
    return {"preset": preset, "seeds": seeds, "scenes": out, "path": path, "reference_settings": settings}


# --- measuring -----------------------------------------------------------------------

def measure_scene(name: str, params, seeds: int, *, render_references: bool, reference_settings=None):
    """The experiment of one gated scene (quick preset sizes), with its reference from
    the cache (GateError when missing, unless ``render_references``)."""
    from volcaustics.reference.cache import existing_reference
    from volcaustics.reference.render import render_reference
    from volcaustics.scenes import SceneError, resolve_scene

    from volcaustics.reports.core.sizing import REPORT_REFERENCE
    from volcaustics.reports.experiment.run import run_experiment

    try:
        scene = resolve_scene(name)
    except SceneError as exc:
        raise GateError(f"budgets: scene {name!r}: {exc}") from None
    p = params.resolved(scene)
    settings = dataclasses.replace(reference_settings or REPORT_REFERENCE, width=p.width, height=p.height)
    reference = existing_reference(scene, settings)
    if reference is None:
        if not render_references:
            raise GateError(f"{name}: no reference in the cache for {p.width}x{p.height}: run `make report` (or "
                            f"the gate with --render-references) first")
        reference = render_reference(scene, settings, progress=False)
    return run_experiment(scene, params, seeds=seeds, reference=reference)


def _number(value, scene, what) -> float:
    if value is None or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise GateError(f"{scene}: {what} is {value!r}: a metric the gate needs is missing or NaN")
    return float(value)


def _step2(segments: list, scene: str) -> dict:
    rows = [r for r in segments if r.get("grouping") == "step" and r.get("step") == 2]
    if not rows:
        raise GateError(f"{scene}: no step-2 segments (steps < 2?): the segment budgets cannot be checked")
    return rows[0]


def budget_checks(scene: str, limits: dict, experiment) -> list:
    """The scene's budgets against its experiment; GateError for a budget the noise
    cannot resolve or a NaN metric."""
    s = experiment.summary
    checks = []
    for name, limit in limits.items():
        group, key = name.split(".", 1)
        if group == "segments":
            row = _step2(experiment.segments, scene)
            if key == "missed_step2_max":
                missed = sum(row.get(f"count_{c}", 0) + row.get(f"count_beyond_self_rehit_{c}", 0)
                             for c in ("missed_inside", "missed_medium"))
                value = _number(missed / row["segments"], scene, name)
            else:
                value = _number(row["abs_dt_p90"], scene, name)
            checks.append(Check(scene, name, value, f"≤ {limit:g}", value <= limit))
            continue
        metrics = s["images"][group]
        if key == "relmse_max":
            m = metrics["relative_mse"]
            value = _number(m["debiased"], scene, f"{group} relative MSE")
            se = m.get("standard_error")
            resolvable = (m.get("reference_floor") or 0.0) + RESOLVE_SIGMAS * (se if se and math.isfinite(se) else 0)
            if limit < resolvable:
                raise GateError(f"{scene}: {name} = {limit:g} is tighter than the noise can resolve (the reference's "
                                f"floor {m.get('reference_floor', 0):.2e} + {RESOLVE_SIGMAS:g} SE = {resolvable:.2e}): "
                                f"raise it or render a finer reference / more seeds")
            checks.append(Check(scene, name, value, f"≤ {limit:g}", value <= limit))
        elif key == "energy_ratio":
            m = metrics["energy_ratio"]
            value = _number(m["value"], scene, f"{group} energy ratio")
            sigma = m.get("reference_sigma") or 0.0
            if (limit[1] - limit[0]) / 2 < RESOLVE_SIGMAS * sigma:
                raise GateError(f"{scene}: {name} = {limit} is narrower than {RESOLVE_SIGMAS:g} σ of the reference's "
                                f"total ({sigma:.2e}): widen it")
            checks.append(Check(scene, name, value, f"in [{limit[0]:g}, {limit[1]:g}]", limit[0] <= value <= limit[1]))
        else:
            value = _number(metrics["hdr_flip"]["value"], scene, f"{group} HDR-FLIP")
            checks.append(Check(scene, name, value, f"≤ {limit:g}", value <= limit))
    for c in checks:
        if not c.passed:
            c.message = f"{scene}: {c.name} = {c.value:.4g}, limit {c.limit}"
    return checks


# --- regression ------------------------------------------------------------------------

def regression_check(scene: str, current: dict, baseline: dict) -> Check:
    """One-sided test of an increase of the per-frame caustic relative MSE over the
    baseline's (paired when the seeds are the same)."""
    from scipy.stats import t as student_t

    import numpy as np

    new = np.asarray(current["caustic_relmse_per_seed"], float)
    old = np.asarray(baseline["caustic_relmse_per_seed"], float)
    if not (np.all(np.isfinite(new)) and np.all(np.isfinite(old))) or len(new) < 2 or len(old) < 2:
        raise GateError(f"{scene}: per-seed caustic errors missing or NaN (current {len(new)}, baseline {len(old)})")
    mean_old = float(old.mean())
    paired = current["seeds"] == baseline["seeds"]
    if paired:
        d = new - old
        se, dof = float(d.std(ddof=1) / np.sqrt(len(d))), len(d) - 1
        increase = float(d.mean())
    else:
        va, vb = new.var(ddof=1) / len(new), old.var(ddof=1) / len(old)
        se = float(np.sqrt(va + vb))
        dof = (va + vb) ** 2 / (va**2 / (len(new) - 1) + vb**2 / (len(old) - 1)) if se > 0 else 1
        increase = float(new.mean() - mean_old)
    if se > 0:
        p = float(student_t.sf(increase / se, dof))
    else:
        p = 1.0 if increase <= 0 else 0.0
    # smallest relative increase detected with POWER at ALPHA by this very test (its SE and dof); a paired
    # comparison of identical frames has no spread: then the unpaired figure, an upper bound
    basis = "this test"
    if se == 0:
        va, vb = new.var(ddof=1) / len(new), old.var(ddof=1) / len(old)
        se = float(np.sqrt(va + vb))
        dof = (va + vb) ** 2 / (va**2 / (len(new) - 1) + vb**2 / (len(old) - 1)) if se > 0 else 1
        basis = "unpaired, an upper bound"
    detectable = ((student_t.ppf(1 - ALPHA, dof) + student_t.ppf(POWER, dof)) * se / mean_old
                  if mean_old > 0 else math.inf)
    passed = not (p < ALPHA and increase > 0)
    relative = increase / mean_old if mean_old > 0 else math.inf
    check = Check(scene, "regression.caustic_relmse", relative, f"p ≥ {ALPHA:g} (one-sided)", passed)
    check.message = (f"{scene}: caustic relative MSE {'+' if relative >= 0 else ''}{100 * relative:.2f}% over the "
                     f"baseline ({'paired' if paired else 'Welch'}, p = {p:.2g}; detectable ≥ {100 * detectable:.1f}% "
                     f"at {len(new)} seeds, {basis})")
    check.detail = {"p": p, "detectable_relative_increase": detectable, "paired": paired,
                    "seeds": len(new), "baseline_seeds": len(old)}
    return check


def baseline_entry(experiment) -> dict:
    s = experiment.summary
    per_seed = s["images"]["caustic"].get("relative_mse", {}).get("per_seed")
    if not per_seed:
        raise GateError(f"{s['scene']}: no per-frame caustic relative MSE "
                        f"({s['images']['caustic'].get('relative_mse', {}).get('note') or 'not computed'})")
    return {"params": s["params"], "seeds": s["seed_values"], "reference_key": s["reference"]["key"],
            "caustic_relmse_per_seed": per_seed, "code_version": s["code_version"]}


def load_baseline(folder: str) -> dict:
    from volcaustics.scenes.storage import read_json_object

    path = os.path.join(folder, BASELINE)
    try:
        doc = read_json_object(path)
    except FileNotFoundError:
        raise GateError(f"{path}: no baseline: run the gate with --update-baseline to accept the current "
                        f"results") from None
    except ValueError as exc:
        raise GateError(f"unreadable baseline: {exc}") from None
    if not isinstance(doc.get("scenes"), dict):
        raise GateError(f"{path}: not a baseline (no \"scenes\" object)")
    for name, entry in doc["scenes"].items():
        ok = (isinstance(entry, dict) and isinstance(entry.get("reference_key"), str)
              and isinstance(entry.get("seeds"), list) and all(isinstance(x, int) for x in entry["seeds"])
              and isinstance(entry.get("caustic_relmse_per_seed"), list)
              and len(entry["caustic_relmse_per_seed"]) == len(entry["seeds"]) >= 2
              and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                      for x in entry["caustic_relmse_per_seed"]))
        if not ok:
            raise GateError(f"{path}: the entry of {name!r} is damaged (reference_key, seeds and one "
                            f"caustic_relmse_per_seed value per seed, at least two, expected): update the baseline")
    return doc


def baseline_text(entries: dict) -> str:
    return json.dumps({"format": 1, "scenes": entries}, indent=1, allow_nan=False)


# --- the run -------------------------------------------------------------------------

def measured_settings(budgets: dict, overrides: dict, *, seeds: int | None, seed: int, min_seeds: int,
                      why: str) -> tuple:
    """(params, seeds) of the gate's experiments: the budgets' preset with ``overrides``
    and first seed ``seed``; ``seeds`` (default: the budgets') at least ``min_seeds``
    (``why`` says why). GateError for a bad override, seed count or seed."""
    from volcaustics.approx.params import PAPER, QUICK, ParamError
    from volcaustics.approx.trace import check_fits

    n_seeds = budgets["seeds"] if seeds is None else seeds
    if isinstance(n_seeds, bool) or not isinstance(n_seeds, int) or not min_seeds <= n_seeds <= 256:
        raise GateError(f"--seeds = {n_seeds!r}: expected an integer in [{min_seeds}, 256] ({why})")
    if not 0 <= seed <= 2**32 - n_seeds:
        raise GateError(f"--seed = {seed}: expected 0 ≤ seed and seed + seeds − 1 < 2^32")
    try:
        params = dataclasses.replace({"quick": QUICK, "paper": PAPER}[budgets["preset"]], seed=seed, **overrides)
        check_fits(params, keep_records=True)  # before any reference renders
    except ParamError as exc:
        raise GateError(f"--set: {exc}") from None
    return params, n_seeds


@dataclass
class GateResult:
    checks: list
    exit_code: int
    seconds: float
    baseline: str | None
    updated_baseline: str | None


def run_gate(budgets: dict, *, overrides: dict, baseline_dir: str | None, update_baseline: bool, out_dir: str,
             scenes=None, seeds: int | None = None, seed: int = 0, render_references: bool = False,
             junit: str | None = None, progress: bool = True) -> GateResult:
    """Measure every budgeted scene (or ``scenes``), check budgets and the baseline, write
    the failure images under ``out_dir`` and then, as one set, the accepted baseline,
    the JUnit file ``junit`` and ``out_dir``/gate.json."""
    import time

    from tqdm import tqdm

    from volcaustics.scenes.storage import remove_file

    t0 = time.perf_counter()
    names = list(scenes) if scenes else list(budgets["scenes"])
    missing = [n for n in names if n not in budgets["scenes"]]
    if missing:
        raise GateError(f"--scenes: {missing[0]!r} has no budgets in {budgets['path']}")
    params, n_seeds = measured_settings(budgets, overrides, seeds=seeds, seed=seed, min_seeds=2,
                                        why="the regression test needs 2")
    baseline = load_baseline(baseline_dir) if baseline_dir and not update_baseline else None
    if baseline is not None:
        absent = [n for n in names if n not in baseline["scenes"]]
        if absent:
            raise GateError(f"{baseline_dir}/baseline.json: no entry for {absent[0]!r}: update the baseline")
    for stale in (os.path.join(out_dir, VERDICT), junit):  # an earlier verdict must not stand for this run
        if stale:
            remove_file(stale)
    checks, entries = [], {}
    for name in tqdm(names, desc="gate", unit="scene", disable=not progress):
        experiment = measure_scene(name, params, n_seeds, render_references=render_references,
                                   reference_settings=budgets["reference_settings"])
        scene_checks = budget_checks(name, budgets["scenes"][name], experiment)
        entry = baseline_entry(experiment)
        entries[name] = entry
        if baseline is not None:
            base = baseline["scenes"][name]
            if base.get("reference_key") != entry["reference_key"]:
                raise GateError(f"{name}: the baseline was measured against reference {base.get('reference_key')}, "
                                f"this run against {entry['reference_key']}: update the baseline")
            scene_checks.append(regression_check(name, entry, base))
        for check in scene_checks:
            if not check.passed:
                check.images = _failure_images(out_dir, name, check, experiment)
        checks += scene_checks
    failed = [c for c in checks if not c.passed]
    # only results that pass their budgets are accepted as the baseline
    updated = os.path.join(baseline_dir, BASELINE) if update_baseline and baseline_dir and not failed else None
    result = GateResult(checks=checks, exit_code=1 if failed else 0, seconds=time.perf_counter() - t0,
                        baseline=baseline_dir, updated_baseline=updated)
    _write_outputs(out_dir, result, params, n_seeds, budgets, baseline=baseline_text(entries) if updated else None,
                   junit=junit)
    return result


def _failure_images(out_dir, scene, check, experiment) -> dict:
    """The caustic as the approximation and the reference see it, and |A − R|, at the
    reference's exposure (PNG) — what a reader of the failure looks at first."""
    import numpy as np

    from volcaustics.metrics.image import reference_exposure
    from volcaustics.scenes.imageio import write_png

    layers = experiment.layers
    a, r = np.asarray(layers["approx"]), np.asarray(layers["reference"])
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


def _write_outputs(out_dir, result: GateResult, params, seeds, budgets, *, baseline: str | None,
                   junit: str | None) -> None:
    """The new baseline (when accepted), the JUnit file and, last, gate.json as one set
    (``scenes.storage.atomic_set``): an interrupted gate never leaves a new baseline
    without its verdict."""
    from volcaustics.scenes.storage import atomic_write_texts

    from volcaustics.reports.experiment.run import plain

    doc = {"passed": result.exit_code == 0, "exit_code": result.exit_code, "seconds": result.seconds,
           "budgets": budgets["path"], "params": params.to_dict(), "seeds": seeds, "baseline": result.baseline,
           "updated_baseline": result.updated_baseline,
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
    from xml.sax.saxutils import escape, quoteattr

    failures = sum(not c.passed for c in checks)
    cases = []
    for c in checks:
        body = ""
        if not c.passed:
            text = c.message + "".join(f"\n{label}: {path}" for label, path in c.images.items())
            body = f"<failure message={quoteattr(c.message)} type=\"budget\">{escape(text)}</failure>"
        cases.append(f"  <testcase classname={quoteattr('volcaustics.gate.' + c.scene)} name={quoteattr(c.name)} "
                     f"time=\"0\">{body}</testcase>")
    return (f"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites tests=\"{len(checks)}\" failures=\"{failures}\">\n"
            f"<testsuite name=\"volcaustics gate\" tests=\"{len(checks)}\" failures=\"{failures}\" errors=\"0\" "
            f"skipped=\"0\" time=\"{seconds:.3f}\">\n" + "\n".join(cases) + "\n</testsuite>\n</testsuites>\n")
