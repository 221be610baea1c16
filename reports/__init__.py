"""The only place that orchestrates: experiments, the measurement runner, sweeps, the
regression gate, the HTML report and the thin ``volcaustics`` CLI, as a tree of
subpackages over a shared core. Their order is stated once, in docs/architecture.md
"The layers", and ``tests/test_import_layers.py`` reads it from there. It drives
``approx`` and ``reference`` on ``scenes`` and hands their arrays to ``metrics``.
"""
