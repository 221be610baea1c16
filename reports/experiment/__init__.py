"""One experiment: a scene, the approximation's parameters, seeds and a reference → both
renders, the exact replay and every metric (``run.run_experiment``), one module per
stage; ``write`` writes what ``measure -o DIR`` keeps."""
