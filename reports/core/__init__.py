"""What every job of ``reports`` shares: presets and the parameter table's command-line
side, the reference's budget and size, the result store, executors, code versions,
tidy tables, plotting, timing, TOML reading and the doctor."""
