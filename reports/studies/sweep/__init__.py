"""Sweeps: a grid over the approximation's parameters measured through the runner into a
resumable store, its figures, the settings that suffice, the variants view and the
density sweep's reading of the model term."""
