"""What results are and where they live: the result store, the typed summaries, tidy
tables, code versions, stage timing, the reference's sizing, the parameter table's
command-line values and the reports' TOML files."""
