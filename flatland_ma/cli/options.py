"""Checked types for the command's options: each turns the option's text into a value
or refuses it, so that ``flatland-ma`` stops with status 2 and the option's name before
any work starts (argparse reports an ``ArgumentTypeError`` as ``argument --steps: ...``).

Counts have a range and an upper bound that keeps the work and the memory they ask for
within what a laptop runs; floats must be finite. An output file must go into a folder
that exists (a missing one is more likely a slip than a wish); an output folder is made,
with the folders above it, where folders can be written.

Checks that need two options at once, or a scenario loaded, raise ``OptionError`` (the
option and the message); the command reports it through its parser in the same way.
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Callable
from pathlib import Path

from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import load_scenario
from flatland_ma.studio.config import MAX_SEED

MAX_EPISODES = 10_000
"""Episodes a command plays per policy, per background or per pair."""
MAX_STEPS = 1_000_000
"""Steps a recording runs at most (it stops earlier when the episode ends)."""
MAX_FRAMES = 1_000
"""Frames a recording holds in memory before writing its video (about 1 MB each)."""
MAX_BENCH_STEPS = 200_000
"""``bench --steps``: the random actions of every row are drawn before the clock starts,
and this many of them fit in a few hundred MB."""
MAX_FPS = 1_000.0
"""``play --fps``: 0 plays as fast as the machine can."""
MAX_BENCH_SECONDS = 600.0
"""``bench --scale --seconds``: per row."""

_DIGITS = re.compile(r"[0-9]{1,19}")
"""A count as the command takes it: plain decimal digits (no sign, exponent or spaces),
short enough that no huge number is ever converted."""


class OptionError(ValueError):
    """An option that is wrong in the light of another option or of what it names."""

    def __init__(self, option: str, message: str):
        super().__init__(f"argument {option}: {message}")
        self.option = option


def count(low: int, high: int, what: str = "") -> Callable[[str], int]:
    """An integer from ``low`` to ``high``, written in decimal digits (``-5``, ``1e8``,
    ``nan`` are refused, each with the range)."""
    extra = f" ({what})" if what else ""

    def parse(text: str) -> int:
        digits = text.strip()
        value = int(digits) if _DIGITS.fullmatch(digits) else None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a whole number from {low:,} to {high:,}{extra}"
            )
        return value

    parse.__name__ = f"count {low}..{high}"
    return parse


def positive(high: int, what: str = "") -> Callable[[str], int]:
    """A whole number from 1 to ``high``."""
    return count(1, high, what)


seed = count(0, MAX_SEED, "a seed")
"""A seed: 0 to ``MAX_SEED``."""


def number(low: float, high: float, zero: str = "") -> Callable[[str], float]:
    """A finite float from ``low`` to ``high`` (``nan``, ``inf`` and ``1e999`` refused).
    ``low`` 0 with ``zero`` set takes 0 too, meaning ``zero``; otherwise a low of 0 is
    excluded (a positive number)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        ok = math.isfinite(value) and value <= high and (value > low or (zero and value == low))
        if not ok:
            floor = f"from {low:g}" if zero else f"above {low:g}"
            meaning = f"; {low:g}: {zero}" if zero else ""
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a finite number {floor} up to {high:g}{meaning}"
            )
        return value

    parse.__name__ = f"number {low:g}..{high:g}"
    return parse


def _writable(path: Path, folder: bool) -> Path:
    """``path`` if a file (``folder`` False) or a folder can be written there. A file must
    be new or a regular file, in a folder that exists. A folder may be missing, with the
    folders above it, if the nearest one that exists can be written (they are made when
    the output is written)."""
    kind = "folder" if folder else "file"
    if str(path) == "":
        raise argparse.ArgumentTypeError(f"an empty path is no {kind}")
    if path.exists():
        if folder and not path.is_dir():
            raise argparse.ArgumentTypeError(f"{str(path)!r} is a file; a folder is wanted")
        if not folder and path.is_dir():
            raise argparse.ArgumentTypeError(f"{str(path)!r} is a folder; a file is wanted")
        if not folder and not path.is_file():
            raise argparse.ArgumentTypeError(f"{str(path)!r} is not a regular file")
        if not os.access(path, os.W_OK):
            raise argparse.ArgumentTypeError(f"{str(path)!r} cannot be written")
        return path
    above = path.absolute().parent
    if not folder and not above.is_dir():
        where = "is a file, not a folder" if above.exists() else "does not exist"
        raise argparse.ArgumentTypeError(
            f"cannot write {str(path)!r}: the folder {str(path.parent)!r} {where}"
        )
    while not above.exists() and above != above.parent:
        above = above.parent
    if not above.is_dir():
        raise argparse.ArgumentTypeError(
            f"cannot make {str(path)!r}: {str(above)!r} is a file, not a folder"
        )
    if not os.access(above, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"cannot make {str(path)!r}: {str(above)!r} is read-only")
    return path


def output_folder(text: str) -> Path:
    """A folder to write into: an existing folder, or one that can be made (with the
    folders above it)."""
    return _writable(Path(text), folder=True)


def output_file(*suffixes: str) -> Callable[[str], Path]:
    """A file to write (any suffix, or one of ``suffixes``): not a folder, nor anything
    but a regular file, and in a folder that exists."""

    def parse(text: str) -> Path:
        path = Path(text)
        if suffixes and path.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(
                f"{text!r}: the file's suffix must be one of {', '.join(suffixes)}"
            )
        return _writable(path, folder=False)

    parse.__name__ = "output file"
    return parse


def recording(text: str) -> Path:
    """``record --out``: a .gif, .mp4 or .png that can be written (MP4 needs PyAV)."""
    from flatland_ma.render.video import SUFFIXES, check_writable

    path = output_file(*SUFFIXES)(text)
    try:
        check_writable(path)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return path


def existing_folder(text: str) -> Path:
    """A folder that is there to be read."""
    path = Path(text)
    if not path.is_dir():
        what = "does not exist" if not path.exists() else "is not a folder"
        raise argparse.ArgumentTypeError(f"{text!r} {what}")
    return path


CHECKPOINT_SUFFIXES = (".safetensors", ".pt")
"""A name with one of these is meant as a checkpoint file (``.pt``: the old format, which
loading refuses with how to convert it)."""


POLICIES = (
    "greedy",
    "wall_follower",
    "planner",
    "carrier",
    "sniffer",
    "signaller",
    "follower",
    "heeder",
    "random",
    "idle",
)
"""The shipped policies' names, as ``policies.named.SHIPPED`` has them (a test keeps the
two equal): the help lists them without importing the policies."""


def policy(text: str) -> str:
    """A shipped policy's name or an existing checkpoint file (its contents are checked
    when it is loaded)."""
    from flatland_ma.policies.named import SHIPPED

    if text in SHIPPED:
        return text
    path = Path(text)
    if path.is_file():
        return text
    shipped = ", ".join(SHIPPED)
    if path.suffix in CHECKPOINT_SUFFIXES or os.sep in text:
        raise argparse.ArgumentTypeError(
            f"checkpoint {text!r} is not a file (policies: {shipped}, or a checkpoint file)"
        )
    raise argparse.ArgumentTypeError(f"no policy {text!r}: one of {shipped}, or a checkpoint file")


def suite(text: str) -> str:
    """A shipped suite's name or a suite file (its contents are checked when loaded)."""
    from flatland_ma.evaluation.suite import list_suites

    if text in list_suites() or Path(text).is_file():
        return text
    raise argparse.ArgumentTypeError(
        f"no suite {text!r}: one of {', '.join(list_suites())}, or a suite file"
    )


def names(text: str) -> list[str]:
    """Comma-separated names (``camera,lidar``), at least one, each a word."""
    items = [t.strip() for t in text.split(",")]
    if not any(items) or not all(re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", t) for t in items):
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of names like camera,lidar")
    return items


def worlds(text: str) -> tuple[int, ...]:
    """``bench --scale --worlds``: comma-separated positive counts (their ceiling is the
    bench's work budget, checked with the scenarios' sizes)."""
    parse = positive(10**9)
    try:
        return tuple(parse(t) for t in text.split(","))
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a comma-separated list of positive whole numbers"
        ) from None


def key_script(text: str) -> str:
    """``play --keys``: a key script that ``play.keys.parse_script`` accepts."""
    from flatland_ma.play.keys import parse_script

    try:
        parse_script(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return text


def world_options(parser: argparse.ArgumentParser) -> None:
    """``--agents`` and ``--sensors``, for commands that build a scenario's world."""
    parser.add_argument(
        "--agents",
        type=positive(10**6),
        default=None,
        help="number of agents, within the scenario format's bounds (default: the "
        "scenario's n_agents)",
    )
    parser.add_argument(
        "--sensors",
        type=names,
        default=None,
        metavar="TYPES",
        help="each agent's sensors by type, each with its default settings, e.g. "
        "camera,lidar,proprioception (default: the scenario's sensors)",
    )


def check_world(args) -> None:
    """The scenario exists and is valid with ``--agents`` and ``--sensors``."""
    try:
        load_scenario(args.scenario)
    except (ScenarioError, ValueError) as err:
        raise OptionError("scenario", str(err)) from None
    overrides = world_overrides(args)
    if overrides:
        given = [o for o, v in (("--agents", args.agents), ("--sensors", args.sensors)) if v]
        try:
            load_scenario(args.scenario, **overrides)
        except (ScenarioError, ValueError, TypeError) as err:
            raise OptionError("/".join(given), str(err)) from None


def world_overrides(args) -> dict:
    """The scenario keys ``--agents`` and ``--sensors`` set."""
    overrides: dict = {}
    if args.agents is not None:
        overrides["n_agents"] = args.agents
    if args.sensors:
        overrides["agent"] = {"sensors": [{"type": t} for t in args.sensors]}
    return overrides


class DefaultsFormatter(argparse.HelpFormatter):
    """Help that gives every option's default: an option whose help does not state it
    (``(default: ...)``) gets ``(default: off)`` for a flag, ``(default: none)`` when
    unset, else its value."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "(default:" in text or not action.option_strings or action.default == argparse.SUPPRESS:
            return text
        if action.nargs == 0:  # a flag (store_true and the like)
            shown = "on" if action.default else "off"
        elif action.default is None:
            shown = "none"
        else:
            shown = str(action.default).replace("%", "%%")
        return f"{text} (default: {shown})".strip()


class DescribedSubParsers(argparse._SubParsersAction):
    """Subcommands whose ``--help`` opens with their one-line help when they were given
    no longer description."""

    def add_parser(self, name: str, **kwargs):
        if kwargs.get("description") is None and kwargs.get("help"):
            text = str(kwargs["help"]).replace("%%", "%")  # a help is %-formatted, this not
            kwargs["description"] = text[0].upper() + text[1:] + "."
        return super().add_parser(name, **kwargs)


class CommandParser(argparse.ArgumentParser):
    """The parser of ``flatland-ma`` and of each of its commands (which inherit it): every
    option's default in the help, every command described."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", DefaultsFormatter)
        super().__init__(*args, **kwargs)
        self.register("action", "parsers", DescribedSubParsers)
