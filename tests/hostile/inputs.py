"""The rows of the hostile corpus beyond scenario files (issue 26): command lines, Python
snippets (API misuse), and the files they read (checkpoints, run folders, streams,
suites), each written into the case's own folder at test time.

A row's ``make(folder)`` writes its input and returns what to run: a ``Command``
(``flatland-ma ARGV``) or a ``Snippet`` (Python). ``tests/test_hostile_inputs.py`` runs it
in a process of its own (``tests/isolated.py``) with a time and a memory limit, in the
folder, and checks the outcome against the row's expectation:

- ``exits(code, *words)``: the command exits with ``code`` (or one of a tuple), prints no
  Python traceback and no "internal error", and its stderr holds every word (for status
  2; for others, stdout or stderr does);
- ``raises(types, *words)``: the snippet raises one of ``types`` (or a subclass), not an
  "internal error", whose message holds every word (in any case);
- ``located(key, *words, source=...)``: the snippet raises a ``ScenarioError`` whose every
  problem names its file; one is at ``key`` or inside it (as printed, ``""`` for the
  whole file), in a file ``source`` matches (default: any), with every word in its
  message;
- ``returns()``: the snippet runs to its end; ``bounded()``: it returns or raises a
  located ``ScenarioError`` (legal but extreme input the package may run or refuse).

Whatever the expectation, the case must not hang, run out of memory or crash, and must
leave no ``MARKER`` in its folder (a checkpoint's payload ran). ``after(folder)`` may
check what the case wrote (a complaint, or None).

``pending`` marks a row expected to fail until a fix lands (strict xfail): set it to
``"issue 26: <class>"``; when the fix is in, empty it (one field per row).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from tests.hostile.archives import MARKER

TIME_LIMIT = 30.0
"""Seconds a case may take: a hostile input is answered well within it."""
TORCH = ("torch",)
"""What the zygote imports once for cases that read checkpoints."""

EXITS, RAISES, LOCATED, RETURNS, BOUNDED = "exits", "raises", "located", "returns", "bounded"


@dataclass(frozen=True)
class Command:
    """``flatland-ma ARGV``, with ``env`` added to the environment."""

    argv: list[str]
    env: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Snippet:
    """Python run with ``folder`` (the case's folder, a ``Path``) in its globals."""

    code: str
    env: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Expect:
    what: str
    code: tuple[int, ...] = ()
    """For ``exits``: the exit statuses accepted (two: refused or done, either is fine)."""
    types: tuple[str, ...] = ()
    """For ``raises``: class names, any of which the exception must be (or derive from)."""
    key: str | None = None
    """For ``located``: the key path of the expected problem; None: any problem."""
    words: tuple[str, ...] = ()
    source: str | None = None
    """For ``located``: a regular expression the problem's source must match (searched)."""


def exits(code: int | tuple[int, ...], *words: str) -> Expect:
    return Expect(EXITS, code=(code,) if isinstance(code, int) else code, words=words)


def raises(types: str | tuple[str, ...], *words: str) -> Expect:
    return Expect(RAISES, types=(types,) if isinstance(types, str) else types, words=words)


def located(key: str | None, *words: str, source: str | None = None) -> Expect:
    return Expect(LOCATED, key=key, words=words, source=source)


def returns() -> Expect:
    return Expect(RETURNS)


def bounded() -> Expect:
    return Expect(BOUNDED)


@dataclass(frozen=True)
class Input:
    """One hostile input of a class, and the outcome expected of it."""

    name: str
    make: Callable[[Path], Command | Snippet]
    expect: Expect
    pending: str = ""
    """Non-empty: expected to fail until a fix lands (strict xfail); the reason."""
    slow: bool = False
    """Only in ``make test-slow`` (seconds of CPU, or a wait for the time limit)."""
    time_limit: float = TIME_LIMIT
    warm: tuple[str, ...] = ()
    """Modules the zygote imports once before forking (``TORCH`` for checkpoints)."""
    after: Callable[[Path], str | None] | None = None
    """A check of what the case left in its folder: a complaint, or None."""


def command(*argv: str, **env: str) -> Callable[[Path], Command]:
    """A ``make`` that writes nothing: the command line alone."""
    return lambda folder: Command(list(argv), dict(env))


def snippet(code: str) -> Callable[[Path], Snippet]:
    return lambda folder: Snippet(code)


def fifo(folder: Path, name: str) -> Path:
    import os

    path = folder / name
    os.mkfifo(path)
    return path


def sparse(folder: Path, name: str, size: int = 2 << 30) -> Path:
    """A file of ``size`` zero bytes that takes no room on disk."""
    path = folder / name
    with open(path, "wb") as f:
        f.truncate(size)
    return path


def symlink_loop(folder: Path, name: str) -> Path:
    path = folder / name
    path.symlink_to(path)
    return path


def marker(folder: Path) -> Path:
    return folder / MARKER
