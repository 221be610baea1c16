"""One experiment: a scene, the approximation's parameters, seeds and a reference → both
renders, the exact replay and every metric (``pipeline.run_experiment``), one module per
stage; ``measure_outputs`` writes what ``measure -o DIR`` keeps."""
