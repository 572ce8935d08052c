"""Hostile suite files: policies, scenarios, focal slots and overrides that do not exist,
a bad task after a good one, a task that cannot be normalised, special files.

Each is loaded with ``load_suite`` and must be refused when it loads (not mid-run) with a
``ScenarioError`` located at the key at fault; a few run through ``evaluate``, which must
exit 2 naming the file (or the task) without a traceback.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from tests.hostile.inputs import Command, Input, Snippet, exits, fifo, located, returns, sparse

P = "issue 26: suites"
FILE = "suite.yaml"
LOAD = f"from flatland_ma.evaluation.suite import load_suite\nload_suite(folder / {FILE!r})\n"
FIELDS = {
    "scenario": "fruits_poisons_multi",
    "focal": "[agent_0]",
    "background": "[idle]",
    "scripted": "[planner]",
    "episodes": "1",
    "overrides": "{episode: {max_steps: 4}}",
}
"""A good task: four-step episodes, one per background."""


def good(**changes: str) -> str:
    """The good task with some fields changed (``focal="[agent_9]"``), as YAML."""
    fields = {**FIELDS, **changes}
    lines = [f"    {key}: {value}\n" for key, value in fields.items() if key != "scenario"]
    return f"  - scenario: {fields['scenario']}\n" + "".join(lines)


def suite(*tasks: str, head: str = "") -> str:
    return head + "tasks:\n" + "".join(tasks)


GOOD = good()


def loaded(text: str | Callable[[Path], str]) -> Callable[[Path], Snippet]:
    def make(folder: Path) -> Snippet:
        (folder / FILE).write_text(text(folder) if callable(text) else text)
        return Snippet(LOAD)

    return make


def evaluated(text: str) -> Callable[[Path], Command]:
    def make(folder: Path) -> Command:
        (folder / FILE).write_text(text)
        return Command(["evaluate", "random", "--suite", FILE, "--no-plot", "--out", "out"])

    return make


def special(name: str, write: Callable[[Path], object]) -> Input:
    def make(folder: Path) -> Snippet:
        write(folder)
        return Snippet(LOAD)

    return Input(name, make, located("", source=FILE))


CASES = [
    Input("valid", loaded(suite(GOOD)), returns()),
    Input(
        "valid_evaluated",
        evaluated(suite(good(scripted="[greedy]", overrides="{episode: {max_steps: 60}}"))),
        exits(0, "fruits_poisons_multi"),
        time_limit=120.0,  # seconds of play, not a hostile input: room for a busy machine
    ),
    Input(
        "background_unknown",
        loaded(suite(good(background="[telepath]"))),
        located("tasks[0].background[0]", "telepath"),
    ),
    Input(
        "background_checkpoint_missing",
        loaded(suite(good(background="[gone.pt]"))),
        located("tasks[0].background[0]", "gone.pt"),
    ),
    Input(
        "scripted_unknown",
        loaded(suite(good(scripted="[oracle]"))),
        located("tasks[0].scripted[0]", "oracle"),
    ),
    Input(
        "scenario_unknown",
        loaded(suite(good(scenario="fruitz"))),
        located("tasks[0].scenario", "fruitz"),
    ),
    Input(
        "scenario_dev_zero",
        loaded(suite(good(scenario="/dev/zero"))),
        located("tasks[0].scenario"),
    ),
    Input(
        "scenario_path_traversal",
        loaded(suite(good(scenario="../../../../../../../../etc/passwd"))),
        located("tasks[0].scenario"),
    ),
    Input(
        "focal_unknown_slot",
        loaded(suite(good(focal="[agent_9]"))),
        located("tasks[0].focal[0]", "agent_9"),
    ),
    Input(
        "focal_every_agent",
        loaded(suite(good(focal="[agent_0, agent_1, agent_2, agent_3]"))),
        located("tasks[0].focal"),
    ),
    Input(
        "overrides_bad",
        loaded(suite(good(overrides="{n_agents: -1}"))),
        located("tasks[0].overrides"),
    ),
    Input(
        "overrides_unknown_key",
        loaded(suite(good(overrides="{n_agnets: 2}"))),
        located("tasks[0].overrides", "n_agnets"),
    ),
    Input(
        "second_task_bad",
        loaded(suite(GOOD, good(scenario="fruitz"))),
        located("tasks[1].scenario", "fruitz"),
    ),
    Input(
        "second_task_bad_evaluated",
        evaluated(suite(GOOD, good(background="[telepath]"))),
        exits(2, FILE, "telepath"),
    ),
    Input(
        # idle partners and a scripted idle focal: scripted play scores what random play
        # does on a four-step episode, so nothing normalises; the task must be named
        "scripted_equals_random_evaluated",
        evaluated(suite(good(scripted="[idle]", overrides="{episode: {max_steps: 1}}"))),
        exits(2, "fruits_poisons_multi"),
    ),
    Input(
        "training_partner_as_background",
        loaded(suite(GOOD, head="training: [idle]\n")),
        located("tasks[0].background[0]", "reserved for training"),
    ),
    Input("episodes_zero", loaded(suite(good(episodes="0"))), located("tasks[0].episodes")),
    Input(
        "not_utf8",
        lambda folder: ((folder / FILE).write_bytes(b"description: \xe9\n"), Snippet(LOAD))[1],
        located("", source=FILE),
    ),
    special("file_is_a_folder", lambda folder: (folder / FILE).mkdir()),
    special("file_is_a_fifo", lambda folder: fifo(folder, FILE)),
    special("file_is_dev_zero", lambda folder: (folder / FILE).symlink_to("/dev/zero")),
    special("file_sparse_2_gib", lambda folder: sparse(folder, FILE)),
]
