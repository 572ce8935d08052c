"""The hostile corpus (issue 14): no scenario file can hang, exhaust or abort the process.

Each row of ``tests/hostile/cases.py`` runs in a process of its own with a time and a
memory limit (``tests/isolated.py``), so that a hang or an abort fails its test instead
of the test run. Its outcome must be the expected one: the scenario works (finite
observations inside their spaces), or it is refused with a located error.
"""

from __future__ import annotations

import re

import pytest

from tests.hostile.cases import BOUNDED, CASES, FOLDER, LOCATED, WORKS, Case
from tests.isolated import Outcome, runner


def marks(case: Case) -> list:
    found = [pytest.mark.slow] if case.slow else []
    if case.pending or case.bug:
        found.append(pytest.mark.xfail(strict=True, reason=case.pending or case.bug))
    return found


@pytest.fixture(scope="module")
def isolated():
    return runner()


@pytest.mark.parametrize(
    "case", [pytest.param(case, id=case.name, marks=marks(case)) for case in CASES]
)
def test_hostile_file(case: Case, isolated, tmp_path):
    path = case.path(tmp_path)
    outcome = isolated.run(path, time_limit=case.time_limit, steps=case.steps)
    report = f"{path.name}: {outcome.summary()}"
    # The runner kills a case at its time limit and caps its address space: a case that
    # needs more of either ends as a timeout or a MemoryError.
    assert outcome.kind not in ("timeout", "memory"), report
    if case.expect == BOUNDED:
        assert outcome.kind in (WORKS, LOCATED), report
    else:
        assert outcome.kind == case.expect, report
    if outcome.kind == WORKS:
        assert outcome.finite and outcome.in_space and outcome.rewards_finite, report
        assert outcome.steps > 0, report
    else:  # every problem names its file, and its line for a fault at a key of a file
        assert not outcome.unplaced(), f"not located: {outcome.unplaced()}\n{report}"
    if case.expect == LOCATED:
        check_located(case, str(path), outcome, report)


def check_located(case: Case, path: str, outcome: Outcome, report: str) -> None:
    """The problem expected is at ``case.key`` in the expected file, with ``case.words``
    in its message."""
    expected = [p for p in outcome.problems if case.key is None or p["key"] == case.key]
    assert expected, f"no problem at {case.key!r}\n{report}"
    problem = expected[0]
    source = case.source or f"^{re.escape(path)}$"
    assert re.search(source, problem["source"]), report
    for words in case.words:
        assert words in problem["message"], f"{words!r} not in the message\n{report}"


def test_every_file_of_the_corpus_has_a_row():
    files = {path.name for path in FOLDER.glob("*.yaml")}
    rows = [case.name for case in CASES if case.make is None]
    assert sorted(rows) == sorted(set(rows)), "a file has two rows"
    assert files == set(rows)
    assert not {case.name for case in CASES if case.make} & files
