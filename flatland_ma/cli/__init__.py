"""The ``flatland-ma`` command line (``python -m flatland_ma.cli`` runs it too):
``main(argv)`` runs one command and returns its exit status; ``build_parser()`` is the
parser of every command and option.

``commands``: the parser and the small commands; ``options``: the checked types of the
options (a wrong one stops the command before any work); one module per larger command:
``bench``, ``evaluate``, ``task_streams`` (``lifelong``), ``convert`` (``checkpoint``),
``studio``.
"""

from flatland_ma.cli.commands import DESCRIPTION, build_parser, main, subcommands

__all__ = ["DESCRIPTION", "build_parser", "main", "subcommands"]
