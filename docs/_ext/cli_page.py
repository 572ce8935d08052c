"""A Sphinx extension that writes the command-line reference (``docs/cli.md``, git-ignored)
from the parser itself when the build starts: every command and subcommand, its usage,
its description, and each argument with its meaning and default. A new option is on the
page at the next build, as ``--help`` shows it."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from pages import cell, write_if_changed

from flatland_ma.cli import DESCRIPTION, build_parser
from flatland_ma.cli.options import DefaultsFormatter

PAGE = "cli.md"
USAGE_COLUMNS = "88"
"""The width usage lines are wrapped to (argparse reads ``COLUMNS``)."""


def cli_page() -> str:
    """The page's Markdown."""
    parser = build_parser()
    parts = [
        "# Command line",
        "",
        f"`flatland-ma`: {DESCRIPTION} Every option is checked before any work starts: a "
        "wrong one stops the command with exit status 2 and a message naming it. This page "
        "is written from the command's parser at every build, so it says what `--help` says.",
        "",
        "| command | what it does |",
        "|---|---|",
    ]
    commands = list(_subcommands(parser))
    parts += [f"| [`{name}`](#{_anchor(name)}) | {cell(help_)} |" for name, help_, _ in commands]
    parts.append("")
    for name, _, sub in commands:
        parts += _section(f"flatland-ma {name}", sub, level=2)
    return "\n".join(parts)


def _section(title: str, parser: argparse.ArgumentParser, level: int) -> list[str]:
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = USAGE_COLUMNS
    try:
        usage = parser.format_usage().removeprefix("usage: ").rstrip()
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old
    parts = ["#" * level + f" {title}", "", "```console", usage, "```", ""]
    if parser.description:
        parts += [_escape(parser.description), ""]
    rows = []
    formatter = DefaultsFormatter(parser.prog)
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        if action.help == argparse.SUPPRESS:
            continue
        text = formatter._expand_help(action)  # as --help shows it
        if isinstance(action, argparse._VersionAction):
            text = "print the version and exit"
        rows.append((_name(action), text))
    if rows:
        parts += ["| argument | meaning |", "|---|---|"]
        parts += [f"| {name} | {cell(_escape(text))} |" for name, text in rows]
        parts.append("")
    for name, _, sub in _subcommands(parser):
        parts += _section(f"{title} {name}", sub, level + 1)
    return parts


def _subcommands(parser: argparse.ArgumentParser):
    """(name, one-line help, parser) of each subcommand of ``parser``."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help for choice in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, (helps.get(name) or "").replace("%%", "%"), sub


def _name(action: argparse.Action) -> str:
    if not action.option_strings:
        return f"`{action.metavar or action.dest}`"
    flags = ", ".join(action.option_strings)
    if action.nargs == 0:
        return f"`{flags}`"
    metavar = action.metavar or action.dest.upper()
    return f"`{flags} {metavar}`"


def _anchor(name: str) -> str:
    return "flatland-ma-" + name.replace(" ", "-")


def _escape(text: str) -> str:
    for mark in ("\\", "*", "<", "[", "]", "`", "_"):
        text = text.replace(mark, "\\" + mark)
    return text


def _on_builder_inited(app) -> None:
    write_if_changed(Path(app.srcdir) / PAGE, cli_page())


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
