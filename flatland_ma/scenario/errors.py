"""Errors about scenario files, each pointing at a file, a line and a key path."""

from __future__ import annotations

from dataclasses import dataclass

KeyPath = tuple  # of str keys and int list indices

Marks = dict[KeyPath, tuple[str, int | None]]
"""For each key path: the file and 1-based line where its value was written."""


def format_path(path: KeyPath) -> str:
    """``("obstacles", 2, "radius")`` -> ``"obstacles[2].radius"``."""
    text = ""
    for part in path:
        if isinstance(part, int):
            text += f"[{part}]"
        else:
            text += ("." if text else "") + str(part)
    return text


@dataclass(frozen=True)
class Problem:
    """One thing wrong with a scenario: where it is and what was expected."""

    source: str
    line: int | None
    path: KeyPath
    message: str

    def __str__(self) -> str:
        where = self.source if self.line is None else f"{self.source}:{self.line}"
        key = format_path(self.path)
        return f"{where}: {key}: {self.message}" if key else f"{where}: {self.message}"


class ScenarioError(ValueError):
    """A scenario that cannot be used; ``problems`` lists every fault found."""

    def __init__(self, problems: list[Problem]):
        self.problems = list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


class UnknownKeywordError(ScenarioError, TypeError):
    """A keyword override that is no top-level key of a scenario (e.g. ``frameskip=1``).

    Also a ``TypeError``, as for any unexpected keyword argument in Python: clients probe
    for optional keywords by catching it (TorchRL's ``GymEnv`` passes ``frameskip``).
    """

    def __init__(self, problems: list[Problem] | str):
        if isinstance(problems, str):  # re-raised with more context, as gymnasium.make does
            self.problems = []
            Exception.__init__(self, problems)
            return
        super().__init__(problems)


class SpecError(ValueError):
    """A fault found by a check that knows which key it concerns (e.g. a layout that
    cannot be built); the loader turns it into a located ``Problem``. ``also`` names
    other keys the fault involves (e.g. the wall an obstacle overlaps), each with its own
    message, reported as problems of their own."""

    def __init__(self, path: KeyPath, message: str, also: tuple = ()):
        super().__init__(message)
        self.path = path
        self.also = tuple(also)


def locate(marks: Marks, path: KeyPath, message: str, fallback: str) -> Problem:
    """Locate ``path`` at its own line, or at the nearest enclosing key that has one."""
    for n in range(len(path), -1, -1):
        if path[:n] in marks:
            source, line = marks[path[:n]]
            return Problem(source, line, tuple(path), message)
    return Problem(fallback, None, tuple(path), message)


def located(err: SpecError, marks: Marks, fallback: str) -> ScenarioError:
    """A ``SpecError`` (and the keys it also involves) as a located ``ScenarioError``."""
    faults = [(err.path, str(err)), *err.also]
    return ScenarioError([locate(marks, path, message, fallback) for path, message in faults])
