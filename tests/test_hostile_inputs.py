"""The hostile corpus beyond scenario files (issue 26): checkpoints (with payloads that
would create a marker file), command lines, lifelong run folders, streams, suites, API
misuse, bodies and sensors.

Each row (``tests/hostile/*_cases.py``) writes its input into its own folder and runs in
a process of its own with a time and a memory limit (``tests/isolated.py``), as a command
line or a Python snippet; its outcome must be the expected one (``tests/hostile/inputs.py``)
and it must leave no marker: no checkpoint can run its author's code.
"""

from __future__ import annotations

import re

import pytest

from tests.hostile import (
    api_cases,
    checkpoint_cases,
    command_cases,
    run_folder_cases,
    stream_cases,
    suite_cases,
)
from tests.hostile.archives import MARKER, PLACES, planted
from tests.hostile.inputs import (
    BOUNDED,
    EXITS,
    LOCATED,
    RAISES,
    RETURNS,
    TORCH,
    Command,
    Expect,
    Input,
)
from tests.isolated import Outcome, runner

CLASSES = {
    "checkpoint": checkpoint_cases.CASES,
    "command": command_cases.CASES,
    "run_folder": run_folder_cases.CASES,
    "stream": stream_cases.CASES,
    "suite": suite_cases.CASES,
    "api": api_cases.CASES,
}
ROWS = [(cls, case) for cls, cases in CLASSES.items() for case in cases]


def marks(case: Input) -> list:
    found = [pytest.mark.slow] if case.slow else []
    if case.pending:
        found.append(pytest.mark.xfail(strict=True, reason=case.pending))
    return found


@pytest.fixture(scope="module")
def isolated():
    return runner()


@pytest.mark.parametrize(
    "case",
    [pytest.param(case, id=f"{cls}-{case.name}", marks=marks(case)) for cls, case in ROWS],
)
def test_hostile_input(case: Input, isolated, tmp_path):
    folder = tmp_path / "case"
    folder.mkdir()
    what = case.make(folder)
    limits = {"env": what.env, "warm": case.warm, "time_limit": case.time_limit}
    if isinstance(what, Command):
        outcome = isolated.command(what.argv, folder, **limits)
        shown = "flatland-ma " + " ".join(what.argv)
    else:
        outcome = isolated.snippet(what.code, folder, **limits)
        shown = what.code
    report = f"{case.name}: {shown}\n{outcome.summary()}"
    assert not (folder / MARKER).exists(), f"the payload ran\n{report}"
    assert outcome.kind not in ("timeout", "memory", "crashed"), report
    check(case.expect, outcome, report)
    if case.after is not None:
        complaint = case.after(folder)
        assert complaint is None, f"{complaint}\n{report}"


def check(expect: Expect, outcome: Outcome, report: str) -> None:
    if expect.what == EXITS:
        assert outcome.kind == "exited" and outcome.exit_code in expect.code, report
        assert not outcome.printed_traceback, f"a traceback was printed\n{report}"
        assert not outcome.internal_error, f"an internal error\n{report}"
        # a refusal (2) is said on stderr; validate reports its files (1) on stdout
        said = outcome.stderr if outcome.exit_code == 2 else outcome.stdout + outcome.stderr
        for words in expect.words:
            assert words in said, f"{words!r} not said\n{report}"
    elif expect.what == RETURNS:
        assert outcome.kind == "returned", report
    elif expect.what == RAISES:
        assert outcome.kind == "raised", report
        assert set(expect.types) & set(outcome.raised_types), report
        assert not outcome.internal_error, f"an internal error\n{report}"
        for words in expect.words:
            assert words.lower() in outcome.detail.lower(), f"{words!r} not said\n{report}"
    elif expect.what == LOCATED:
        check_located(expect, outcome, report)
    else:
        assert expect.what == BOUNDED
        assert outcome.kind in ("returned", "raised"), report
        if outcome.kind == "raised":
            check_located(expect, outcome, report)


def check_located(expect: Expect, outcome: Outcome, report: str) -> None:
    assert outcome.kind == "raised" and "ScenarioError" in outcome.raised_types, report
    assert not outcome.internal_error, f"an internal error\n{report}"
    assert outcome.problems and not outcome.unplaced(), f"not located\n{report}"
    at = [p for p in outcome.problems if expect.key is None or inside(p["key"], expect.key)]
    assert at, f"no problem at {expect.key!r}\n{report}"
    problem = at[0]
    if expect.source is not None:
        assert re.search(expect.source, problem["source"]), report
    for words in expect.words:
        assert words in problem["message"], f"{words!r} not in the message\n{report}"


def inside(key: str, expected: str) -> bool:
    """Whether a problem at ``key`` is at ``expected`` or inside it (an item, a field)."""
    return key == expected or key.startswith((f"{expected}[", f"{expected}."))


def test_every_row_has_its_own_name():
    names = [f"{cls}-{case.name}" for cls, case in ROWS]
    assert len(names) == len(set(names))


@pytest.mark.parametrize("place", PLACES)
def test_each_planted_payload_runs_when_unpickled(place, isolated, tmp_path):
    """The payloads are live: ``torch.export.load`` of each planted program creates the
    marker, so a loader that leaves none has refused the file, not met a dud."""
    (tmp_path / "program.pt2").write_bytes(planted(place, tmp_path / MARKER))
    code = "import torch\ntry:\n    torch.export.load(folder / 'program.pt2')\nexcept Exception:\n"
    code += "    pass  # the payload ran before the program was found broken"
    # a check of the payload, not a hostile input: room for torch on a busy machine
    outcome = isolated.snippet(code, tmp_path, warm=TORCH, time_limit=120.0)
    assert outcome.kind == "returned", outcome.summary()
    assert (tmp_path / MARKER).exists(), outcome.summary()


def test_the_runner_captures_a_command_and_confines_it_to_its_folder(isolated, tmp_path):
    outcome = isolated.command(["list"], tmp_path)
    assert outcome.kind == "exited" and outcome.exit_code == 0, outcome.summary()
    assert "fruits_poisons" in outcome.stdout and not outcome.printed_traceback
    outcome = isolated.snippet("open('here.txt', 'w').write('x')\nraise KeyError('k')", tmp_path)
    assert (tmp_path / "here.txt").read_text() == "x"
    assert outcome.kind == "raised" and outcome.raised_types[:2] == ["KeyError", "LookupError"]
    outcome = isolated.command(["record", "nosuch", "--steps", "1"], tmp_path)
    assert outcome.kind == "exited" and outcome.exit_code == 2, outcome.summary()


def test_an_escaping_exception_is_a_printed_traceback_and_status_1(isolated, tmp_path):
    broken = "import flatland_ma.cli as cli\ncli.main = lambda argv: 1 / 0"
    outcome = isolated.command(["list"], tmp_path, prelude=broken)
    assert outcome.kind == "exited" and outcome.exit_code == 1, outcome.summary()
    assert outcome.printed_traceback and "ZeroDivisionError" in outcome.stderr
    outcome = isolated.command(["list"], tmp_path, prelude="print('internal error: x')")
    assert outcome.exit_code == 0 and outcome.internal_error, outcome.summary()
