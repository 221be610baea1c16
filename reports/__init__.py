"""The only place that orchestrates: experiments, sweeps, the regression gate,
the HTML report, executors and the thin ``volcaustics`` CLI (``reports.cli``).
It drives ``approx`` and ``reference`` on ``scenes`` and hands their arrays to
``metrics``.
"""
