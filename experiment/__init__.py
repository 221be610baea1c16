"""One experiment: a scene, the approximation's parameters, seeds and a reference → both
renders, the exact replay and every metric (``pipeline.run_experiment``), one module per
stage, and its result as typed values (``result.Experiment``) read from and written to its
stored summary (``summaries``). The layer between the renderers (``approx``,
``reference``, ``metrics``) and the harness (``reports``), which alone runs, stores and
shows experiments."""
