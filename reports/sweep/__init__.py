"""Sweeps: a grid over the approximation's parameters measured through the runner into a
resumable store, its figures and the settings that suffice."""
