"""The accuracy report: results gathered through the runner, the summary every number on
the page comes from, the self-contained HTML page, its pictures and charts."""
