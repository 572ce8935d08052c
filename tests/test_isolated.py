"""The isolated runner (``tests/isolated.py``) reports what a case did, whatever it did:
abort, segfault, hang, run out of memory, or work; and its zygote lives on after each."""

from __future__ import annotations

import os

import pytest

from tests.isolated import Runner, runner

SCENARIO = "fruits_poisons"


@pytest.fixture(scope="module")
def isolated():
    return runner()


@pytest.mark.parametrize(
    "prelude, kind, detail",
    [
        ("import os; os.abort()", "crashed", "killed by SIGABRT"),
        ("import ctypes; ctypes.string_at(0)", "crashed", "killed by SIGSEGV"),
        ("import os; os._exit(3)", "crashed", "exited with code 3"),
        ("x = bytearray(4 << 30)", "memory", "MemoryError"),
        ("while True: pass", "timeout", "used its 1 s of CPU time"),
        ("import time; time.sleep(10**6)", "timeout", "still running after 3 s (hangs)"),
    ],
    ids=["abort", "segfault", "exit", "memory", "spin", "hang"],
)
def test_a_case_that_dies_is_reported_and_the_zygote_serves_on(isolated, prelude, kind, detail):
    # Only the sleeping case is cut short by the wall clock; the others end by themselves
    # (the spinning one at its 1 s of CPU, however long a busy machine makes that take).
    hang_after = 3.0 if "sleep" in prelude else None
    outcome = isolated.run(SCENARIO, prelude=prelude, time_limit=1.0, hang_after=hang_after)
    assert outcome.kind == kind and detail in outcome.detail, outcome.summary()
    assert isolated.run(SCENARIO).kind == "works"


def test_a_working_case_reports_its_figures(isolated):
    outcome = isolated.run(SCENARIO, prelude="print('noise' * 100_000)", steps=7)
    assert outcome.kind == "works", outcome.summary()
    assert outcome.steps == 14 and outcome.finite and outcome.in_space
    assert 0 < outcome.load_s < outcome.wall_s and 0 < outcome.reset_s < outcome.wall_s
    assert 0 < outcome.start_rss_mb <= outcome.peak_rss_mb
    assert "works in" in outcome.summary() and "peak RSS" in outcome.summary()


def test_the_memory_limit_is_the_budget_on_top_of_the_zygote(isolated):
    small = "x = bytearray(100 << 20); x[::4096] = b'1' * len(x[::4096])"
    outcome = isolated.run(SCENARIO, prelude=small, memory_budget_mb=400)
    assert outcome.kind == "works" and outcome.grown_mb > 90, outcome.summary()
    outcome = isolated.run(SCENARIO, prelude="x = bytearray(500 << 20)", memory_budget_mb=400)
    assert outcome.kind == "memory", outcome.summary()


def test_overrides_reach_the_case_with_their_extreme_numbers(isolated):
    outcome = isolated.run(SCENARIO, {"agent": {"mass": float("nan")}})
    assert outcome.kind == "located", outcome.summary()
    (problem,) = outcome.problems
    assert problem["source"] == "<overrides>" and problem["key"] == "agent.mass"
    assert "finite" in problem["message"]
    outcome = isolated.run(SCENARIO, {"physics": {"dt": 5e-324}})
    assert "got 5e-324" in outcome.problems[0]["message"], outcome.summary()


def test_errors_other_than_scenario_errors_are_other_exceptions(isolated):
    outcome = isolated.run("no/such/file.yaml")
    assert outcome.kind == "other-exception" and outcome.phase == "load", outcome.summary()
    assert "ValueError" in outcome.detail and "does not exist" in outcome.detail


def test_the_zygote_exits_when_its_runner_closes():
    own = Runner()
    assert own.run(SCENARIO).kind == "works"
    process = own._process
    assert process is not None and process.poll() is None
    own.close()
    assert process.returncode == 0
    with pytest.raises(ProcessLookupError):
        os.kill(process.pid, 0)
