"""The only place that orchestrates: experiments, the measurement runner, sweeps, the
regression gate, the HTML report and the thin ``volcaustics`` CLI, as a tree of
subpackages over a shared core (docs/architecture.md; imports run one way, core ←
{experiment, render} ← runner ← gate ← sweep ← page ← cli, enforced by
``tests/test_import_layers.py``). It drives ``approx`` and ``reference`` on ``scenes``
and hands their arrays to ``metrics``.
"""
