"""The gate's regression test: per scene, each frame's caustic relative MSE against the
baseline's (the last accepted results, ``baseline.json``, with the reference keys they
were measured against). Same seeds: a paired one-sided t-test (an unchanged
approximation gives identical frames: no false alarm at all); other seeds: Welch's. A
regression is an increase significant at ``ALPHA``; the gate states the smallest
relative increase it detects with ``POWER`` at its seed count."""

from __future__ import annotations

import json
import math
import os
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import t as student_t

from volcaustics.infra.storage import read_json_object
from volcaustics.reports.studies.gate.budgets import Check, GateError

if TYPE_CHECKING:
    from volcaustics.reports.studies.gate.budgets import MeasuredResult

ALPHA = 0.01            # one-sided false-alarm rate of the regression test
POWER = 0.95            # for the stated detectable increase
BASELINE = "baseline.json"  # in --baseline


def regression_check(scene: str, current: dict, baseline: dict) -> Check:
    """One-sided test of an increase of the per-frame caustic relative MSE over the
    baseline's (paired when the seeds are the same)."""
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


def baseline_entry(result: MeasuredResult) -> dict:
    """The result as the baseline keeps it: its parameters, seeds, reference and each
    frame's caustic relative MSE; GateError without the per-frame values."""
    e = result.experiment
    relmse = e.find_metric("relative_mse", "caustic")
    if relmse is None or not relmse.per_seed:
        raise GateError(f"{e.scene}: no per-frame caustic relative MSE "
                        f"({(relmse.note if relmse is not None else '') or 'not computed'})")
    return {"params": e.params.to_dict(), "seeds": list(e.seed_values),
            "reference_key": e.reference.key if e.reference is not None else None,
            "caustic_relmse_per_seed": list(relmse.per_seed), "code_version": e.code_version}


def load_baseline(folder: str) -> dict:
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise GateError(f"--baseline {folder}: is a file: it must be a folder, the one holding {BASELINE} "
                        f"(`make gate-baseline` writes one)")
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
