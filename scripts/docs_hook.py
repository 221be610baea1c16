"""MkDocs hook (mkdocs.yml ``hooks``): fills ``commands.md``'s placeholder with the command
reference generated from the argparse parsers (``volcaustics.reports.cli.reference_page``),
so the page is rebuilt from the flags every time the site is."""

import os

PLACEHOLDER = "<!-- generated: command reference -->"


def on_page_markdown(markdown, page, config, files):
    if PLACEHOLDER not in markdown:
        return markdown
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal: a fixed width makes the page reproducible
    from volcaustics.reports.cli import build_parser
    from volcaustics.reports.cli.reference_page import command_reference

    return markdown.replace(PLACEHOLDER, command_reference(build_parser()))
