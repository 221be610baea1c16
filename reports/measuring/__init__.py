"""Measuring (docs/architecture.md): one point's experiment (``experiment``), the result
store and what every stage shares (``results``), where work runs (``pools``), the one
runner that takes points through them (``runner``) and the machine's own check."""
