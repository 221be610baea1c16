"""The command reference as Markdown, generated from the argparse parsers themselves
(the docs site's ``commands.md`` is built from it by ``scripts/docs_hook.py``, so the page
cannot drift from the flags)."""

from __future__ import annotations

import argparse


def _subparsers(parser: argparse.ArgumentParser) -> dict:
    """Command name → its parser, in the order the commands were registered."""
    for action in parser._actions:  # argparse has no public accessor for its subparsers
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def command_reference(parser: argparse.ArgumentParser) -> str:
    """One section per command: its one-line purpose and its ``--help`` text verbatim."""
    helps = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help for choice in action._choices_actions}
    parts = []
    for name, sub in _subparsers(parser).items():
        text = sub.format_help().replace("```", "'''")
        purpose = helps.get(name) or ""
        parts.append(f"### `volcaustics {name}`\n\n{purpose}\n\n```text\n{text.rstrip()}\n```\n")
    return "\n".join(parts)
