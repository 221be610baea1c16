"""Studies built of measured points (docs/architecture.md): sweeps, the best-configuration
search and its frame check, the regression gate, animations over time, and other
renderers compared."""
