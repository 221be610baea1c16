"""ApproxParams is declared in source: a frozen dataclass whose fields carry their Param,
so a type checker sees every field; PARAMS is those fields' table."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import pytest

from volcaustics.approx.params import PARAMS, ApproxParams, params_class

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_the_fields_carry_the_table():
    fields = dataclasses.fields(ApproxParams)
    assert [f.name for f in fields] == [p.name for p in PARAMS]
    assert all(f.metadata["param"] is p and f.default == p.default for f, p in zip(fields, PARAMS))
    # the table's other class (a parameter being added) gives the same parameters
    assert params_class(PARAMS)(layers=2).to_dict() == ApproxParams(layers=2).to_dict()


@pytest.mark.slow  # a whole mypy run over the params module's imports (13-14 s, cold cache): make lint types the rest
def test_mypy_sees_the_fields(tmp_path):
    """A probe using the fields type-checks; the same probe with a misspelt field and a
    misspelt keyword fails with both named (the negative control)."""
    good = "from volcaustics.approx.params import ApproxParams\np = ApproxParams(layers=2)\nn: int = p.layers\n"
    bad = good + "m = p.layerz\nq = ApproxParams(photon_ress=3)\n"
    for name, text in (("good", good), ("bad", bad)):
        (tmp_path / f"{name}.py").write_text(text)
    # one mypy run for both probes (a run costs ~6 s: the params module's imports)
    run = subprocess.run([sys.executable, "-m", "mypy", str(tmp_path / "good.py"), str(tmp_path / "bad.py"),
                          "--follow-imports=silent", "--no-error-summary", "--cache-dir", str(tmp_path / "cache")],
                         capture_output=True, text=True, cwd=ROOT, timeout=300)
    out = run.stdout
    assert "good.py" not in out, out
    assert run.returncode == 1 and '"layerz"' in out and '"photon_ress"' in out, out
