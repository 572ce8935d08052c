"""Suite files resolved when they load: unknown policies, scenarios, focal slots, bad
overrides and missing checkpoints are refused with the file, the line and the key path
before any task plays; a task whose scale cannot be set is named when it plays."""

from __future__ import annotations

import os

import pytest

pytest.importorskip("scipy")

from flatland_ma.evaluation import load_suite, run_suite  # noqa: E402
from flatland_ma.scenario.errors import ScenarioError  # noqa: E402

GOOD = """\
training: [greedy]
tasks:
  - scenario: fruits_poisons_multi
    focal: [agent_0]
    background: [planner, idle]
    scripted: [planner]
    episodes: 1
    overrides: {episode: {max_steps: 30}}
"""
SECOND = """\
  - scenario: plate_relay
    focal: [runner]
    background: [planner, idle]
    scripted: [planner]
    episodes: 1
"""


def located(path, text: str, where: str, words: str, line: int | None = None) -> str:
    """Loading ``text`` written at ``path`` fails with one located problem at ``where``."""
    path.write_text(text)
    with pytest.raises(ScenarioError) as caught:
        load_suite(path)
    problem = caught.value.problems[0]
    assert problem.source == str(path) and problem.line is not None, str(problem)
    if line is not None:
        assert problem.line == line, str(problem)
    assert str(problem).startswith(f"{path}:{problem.line}: {where}: "), str(problem)
    assert words in problem.message, str(problem)
    return str(problem)


BG = "background: [planner, idle]"


@pytest.mark.parametrize(
    "old, new, where, words, line",
    [
        (BG, "background: [planner, idel]", "background[1]", "idle", 11),
        ("scripted: [planner]", "scripted: [planer]", "scripted[0]", "no policy 'planer'", 12),
        (BG, "background: [idle, nope.pt]", "background[1]", "no such file", 11),
        ("scenario: plate_relay", "scenario: plate_rely", "scenario", "did you mean", 9),
        ("focal: [runner]", "focal: [pilot]", "focal[0]", "'pilot' is no agent or team", 10),
        ("focal: [runner]", "focal: [runner, scout]", "focal", "every agent is focal", 10),
        (BG, "background: [idle, sniffer]", "background[1]", "smell", 11),
    ],
)
def test_a_bad_second_task_is_refused_at_load_before_the_first_plays(
    tmp_path, old, new, where, words, line
):
    text = GOOD + SECOND.replace(old, new)
    located(tmp_path / "suite.yaml", text, f"tasks[1].{where}", words, line)


def test_bad_overrides_are_located_at_their_own_key(tmp_path):
    text = GOOD.replace(
        "overrides: {episode: {max_steps: 30}}",
        "overrides:\n      episode: {max_steps: 30}\n      items: [{name: x, color: nocolour}]",
    )
    located(tmp_path / "s.yaml", text, "tasks[0].overrides.items[0].color", "nocolour", 10)
    text = GOOD.replace("{episode: {max_steps: 30}}", "{episode: {max_steps: 30}, frameskip: 4}")
    located(tmp_path / "s.yaml", text, "tasks[0].overrides.frameskip", "frameskip", 8)


def test_a_scenario_that_is_no_scenario_is_blamed_on_the_scenario_key(tmp_path):
    (tmp_path / "a.yaml").write_text("extends: b.yaml\n")
    (tmp_path / "b.yaml").write_text("extends: a.yaml\n")
    cycle = GOOD.replace("fruits_poisons_multi", str(tmp_path / "a.yaml"))
    located(tmp_path / "s.yaml", cycle, "tasks[0].scenario", "a cycle", 3)
    itself = GOOD.replace("fruits_poisons_multi", str(tmp_path / "s.yaml"))
    located(tmp_path / "s.yaml", itself, "tasks[0].scenario", "not a scenario", 3)
    (tmp_path / "folder.yaml").mkdir()
    folder = GOOD.replace("fruits_poisons_multi", str(tmp_path / "folder.yaml"))
    located(tmp_path / "s.yaml", folder, "tasks[0].scenario", "a directory", 3)


def test_a_checkpoint_that_is_no_regular_file_and_an_unknown_training_partner(tmp_path):
    (tmp_path / "policy.pt").mkdir()
    text = GOOD.replace("[planner, idle]", f"[planner, {tmp_path / 'policy.pt'}]")
    located(tmp_path / "s.yaml", text, "tasks[0].background[1]", "a directory", 5)
    located(tmp_path / "s.yaml", GOOD.replace("[greedy]", "[gredy]"), "training[0]", "greedy", 1)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_suite_file_that_is_a_fifo_a_folder_or_a_device_is_refused(tmp_path):
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)  # opened without blocking: no writer is needed for the refusal
    for path, words in ((fifo, "a FIFO"), (tmp_path, "a directory"), ("/dev/zero", "a device")):
        with pytest.raises(ScenarioError, match=f"^{path}: {words}"):
            load_suite(path)


def test_the_normalisation_error_names_the_task_when_scripted_play_is_random(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD.replace("scripted: [planner]", "scripted: [random]"))
    suite = load_suite(path)
    with pytest.raises(ScenarioError) as caught:
        run_suite(suite, "idle", episodes=1)
    problem = caught.value.problems[0]
    assert (problem.source, problem.line) == (str(path), 6)
    assert str(problem).startswith(f"{path}:6: tasks[0].scripted: task fruits_poisons_multi")
    assert "must score above random play" in problem.message


def test_the_shipped_suite_still_loads_with_every_reference_resolved():
    suite = load_suite("society")
    assert len(suite.tasks) >= 8 and suite.source.endswith("society.yaml")
