"""Stream files held to the scenario files' standard when they load: drift bounds finite
and plausible, every background policy and checkpoint resolved, a bad task scenario
blamed on ``scenario`` (not ``overrides``), and a stream file that is no regular file
refused; each fault with the file, the line and the key path."""

from __future__ import annotations

import os

import numpy as np
import pytest

from flatland_ma.lifelong import load_stream
from flatland_ma.lifelong.drift import reflect
from flatland_ma.lifelong.streams import DriftSpec
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.types import MAX_REWARD

MULTI = "{name: %s, scenario: fruits_poisons_multi, focal: [agent_0], background: %s, steps: 5}"


def located(path, text: str, where: str, words: str, line: int) -> str:
    """Loading ``text`` written at ``path`` fails first at ``where``, on ``line``."""
    path.write_text(text)
    with pytest.raises(ScenarioError) as caught:
        load_stream(path)
    problem = caught.value.problems[0]
    assert (problem.source, problem.line) == (str(path), line), str(problem)
    assert str(problem).startswith(f"{path}:{line}: {where}: "), str(problem)
    assert words in problem.message, str(problem)
    return problem.message


@pytest.mark.parametrize(
    "bounds, words",
    [
        ("[-1.0e+308, 1.0e+308]", "-1e+308: each bound must be finite and within ±1e+06"),
        ("[-.inf, 1]", "-inf: each bound must be finite"),
        ("[1, .nan]", "nan: each bound must be finite"),
        ("[-1e308, 1]", "got '-1e308' (YAML reads a number with an exponent but no dot"),
        ('["-1", 1]', "expected two numbers [low, high], got '-1'"),
        ("[true, 1]", "expected two numbers [low, high], got True"),
        ("[1, 2, 3]", "expected [low, high], got [1, 2, 3]"),
    ],
)
def test_drift_bounds_must_be_finite_numbers_a_scenario_could_hold(tmp_path, bounds, words):
    text = (
        "never_ending:\n  scenario: fruits_poisons\n"
        f"  drift:\n    value_step: 0.1\n    value_bounds: {bounds}\n"
    )
    where = "never_ending.drift.value_bounds"
    located(tmp_path / "drift.yaml", text, where, words, 5)


def test_the_widest_drift_bounds_reflect_without_overflow():
    """With ±1e308 the span overflowed and every value folded to 0; the widest bounds now
    allowed keep values inside them as they are and fold the others back."""
    spec = DriftSpec(value_bounds=(-MAX_REWARD, MAX_REWARD))
    low, high = spec.value_bounds
    values = np.array([-10.0, 0.5, 10.0, 999_999.0])
    assert np.array_equal(reflect(values, low, high), values)
    assert reflect(np.array([high + 5.0]), low, high)[0] == pytest.approx(high - 5.0)


def test_an_unknown_background_policy_fails_at_load_naming_file_line_and_key(tmp_path):
    text = "tasks:\n  - " + MULTI % ("a", "greedy") + "\n  - " + MULTI % ("b", "gredy") + "\n"
    message = located(tmp_path / "s.yaml", text, "tasks[1].background", "no policy 'gredy'", 3)
    assert "did you mean 'greedy'" in message


def test_a_missing_or_irregular_checkpoint_fails_at_load(tmp_path):
    missing = tmp_path / "gone.pt"
    text = "tasks:\n  - " + MULTI % ("a", missing) + "\n"
    located(tmp_path / "s.yaml", text, "tasks[0].background", "no such file", 2)
    missing.mkdir()
    located(tmp_path / "s.yaml", text, "tasks[0].background", "a directory", 2)
    if hasattr(os, "mkfifo"):
        fifo = tmp_path / "fifo.pt"
        os.mkfifo(fifo)  # checked by its status, never opened: nothing waits for a writer
        text = "tasks:\n  - " + MULTI % ("a", fifo) + "\n"
        located(tmp_path / "s.yaml", text, "tasks[0].background", "a FIFO", 2)


def test_a_background_policy_that_cannot_drive_the_agents_fails_at_load(tmp_path):
    text = "tasks:\n  - " + MULTI % ("a", "sniffer") + "\n"
    located(tmp_path / "s.yaml", text, "tasks[0].background", "smell", 2)


def task(scenario: str) -> str:
    return (
        f"tasks:\n  - name: a\n    scenario: {scenario}\n"
        "    overrides: {episode: {max_steps: 10}}\n    steps: 5\n"
    )


def test_a_bad_task_scenario_is_blamed_on_scenario_not_overrides(tmp_path):
    folder = tmp_path / "streams"
    folder.mkdir()
    (tmp_path / "outside.txt").write_text("secret: [1, 2]\n")
    message = located(
        folder / "s.yaml", task("../outside.txt"), "tasks[0].scenario", "outside.txt", 3
    )
    assert "secret" in message  # the fault of the file reached, blamed on the reference
    located(folder / "s.yaml", task("s.yaml"), "tasks[0].scenario", "not a scenario", 3)
    (folder / "a.yaml").write_text("extends: b.yaml\n")
    (folder / "b.yaml").write_text("extends: a.yaml\n")
    located(folder / "s.yaml", task("a.yaml"), "tasks[0].scenario", "a cycle", 3)
    (folder / "dir.yaml").mkdir()
    located(folder / "s.yaml", task("dir.yaml"), "tasks[0].scenario", "a directory", 3)


def test_a_fault_of_the_overrides_is_located_at_the_override_itself(tmp_path):
    text = (
        "tasks:\n  - name: a\n    scenario: fruits_poisons\n    steps: 5\n    overrides:\n"
        "      episode: {max_steps: 10}\n      items:\n        - {name: x, color: nocolour}\n"
    )
    where = "tasks[0].overrides.items[0].color"
    located(tmp_path / "s.yaml", text, where, "unknown colour name 'nocolour'", 8)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_stream_file_that_is_a_fifo_a_folder_or_a_device_is_refused(tmp_path):
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    (tmp_path / "folder.yaml").mkdir()
    cases = ((fifo, "a FIFO"), (tmp_path / "folder.yaml", "a directory"), ("/dev/zero", "a device"))
    for path, words in cases:
        with pytest.raises(ScenarioError, match=f"^{path}: {words}"):
            load_stream(path)
