"""Every command's help is complete: each option states its default, each command and
subcommand has a description, and the policies listed are every shipped one."""

import argparse

from flatland_ma.cli import build_parser, main, options
from flatland_ma.policies.named import SHIPPED


def commands(parser: argparse.ArgumentParser, name: str = "flatland-ma"):
    """Each parser under ``parser`` (itself included), with its command line."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, child in action.choices.items():
                yield from commands(child, f"{name} {sub}")


def test_every_option_of_every_command_shows_its_default():
    missing = []
    for name, parser in commands(build_parser()):
        formatter = parser._get_formatter()
        for action in parser._actions:
            if not action.option_strings or action.help == argparse.SUPPRESS:
                continue
            if isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
                continue
            text = formatter._expand_help(action)  # as --help shows it
            if "(default:" not in text:
                missing.append(f"{name} {action.option_strings[0]}")
    assert missing == []


def test_every_command_has_a_description():
    assert [name for name, parser in commands(build_parser()) if not parser.description] == []


def test_the_help_lists_every_shipped_policy(capsys):
    assert options.POLICIES == tuple(SHIPPED)
    assert main(["record", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert f"one of {', '.join(SHIPPED)}, or the path of a checkpoint" in text


def test_a_flag_and_an_unset_option_show_off_and_none(capsys):
    assert main(["bench", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "print the figures as JSON (default: off)" in text
    assert main(["play", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "a PNG of the window at the end (default: none)" in text
