"""Hostile stream files: drift bounds that overflow, references (scenarios, background
policies, checkpoints) that lead nowhere or back to the stream, special files.

Each is loaded with ``load_stream`` (a few are then played: built and reset), and must be
refused when it loads with a ``ScenarioError`` located at the key at fault (file, line,
key path), or work.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

from tests.hostile.inputs import Input, Snippet, bounded, fifo, located, returns, sparse

P = "issue 26: streams"
FILE = "stream.yaml"
LOAD = f"from flatland_ma.lifelong.streams import load_stream\nload_stream(folder / {FILE!r})\n"
PLAYED = (
    "from flatland_ma.lifelong.envs import StreamParallelEnv\n"
    f"env = StreamParallelEnv(folder / {FILE!r})\n"
    "env.reset(seed=0)\n"
    "env.step({a: env.action_space(a).sample() for a in env.agents})\n"
)
TASK = "  - {{name: t, scenario: {scenario}, steps: 10{more}}}\n"
DRIFT = "never_ending:\n  scenario: fruits_poisons\n  drift: {{value_bounds: {bounds}}}\n"


TWO_TASKS = """tasks:
  - {name: first, scenario: fruits_poisons, steps: 10}
  - {name: second, scenario: fruits_poisons, steps: 10, overrides: {items: []}}
"""


def stream(text: str | Callable[[Path], str], code: str = LOAD) -> Callable[[Path], Snippet]:
    def make(folder: Path) -> Snippet:
        (folder / FILE).write_text(text(folder) if callable(text) else text)
        return Snippet(code)

    return make


def task(scenario: str, more: str = "") -> str:
    return "tasks:\n" + TASK.format(scenario=scenario, more=more)


def multi(background: str) -> str:
    return task("fruits_poisons_multi", f", focal: [agent_0], background: {background}")


def drift(bounds: str, key: str = "never_ending.drift.value_bounds", **options) -> Input:
    name = "drift_bounds_" + re.sub(r"\W+", "_", bounds).strip("_")
    return Input(name, stream(DRIFT.format(bounds=bounds)), located(key), **options)


def special(name: str, write: Callable[[Path], object], **options) -> Input:
    """The stream file itself replaced by something that is not a regular file."""

    def make(folder: Path) -> Snippet:
        write(folder)
        return Snippet(LOAD)

    return Input(name, make, located("", source=FILE), **options)


def cycle(folder: Path) -> str:
    (folder / "a.yaml").write_text(f"extends: {folder / 'b.yaml'}\n")
    (folder / "b.yaml").write_text(f"extends: {folder / 'a.yaml'}\n")
    return task(str(folder / "a.yaml"))


CASES = [
    Input("valid_two_tasks", stream(TWO_TASKS), returns()),
    Input("valid_played_with_background", stream(multi("idle"), PLAYED), returns()),
    drift("[-1.0e+308, 1.0e+308]"),
    drift("[-.inf, .inf]"),
    drift("[-1, .nan]"),
    drift("[low, high]"),
    drift("[5, 5]", key="never_ending.drift"),
    Input(
        "drift_value_step_huge",
        stream("never_ending: {scenario: fruits_poisons, drift: {value_step: 1e308}}\n"),
        located("never_ending.drift.value_step"),
    ),
    Input(
        "drift_move_nan",
        stream("never_ending: {scenario: fruits_poisons, drift: {move: .nan}}\n"),
        located("never_ending.drift.move"),
    ),
    Input(
        "background_unknown", stream(multi("telepath")), located("tasks[0].background", "telepath")
    ),
    Input(
        "background_unknown_played",
        stream(multi("telepath"), PLAYED),
        located("tasks[0].background", "telepath"),
    ),
    Input(
        "background_checkpoint_missing",
        stream(multi("gone.pt")),
        located("tasks[0].background", "gone.pt"),
    ),
    Input(
        "scenario_path_traversal",
        stream(task("../../../../../../../../etc/passwd")),
        located("tasks[0].scenario"),
    ),
    Input(
        "scenario_the_stream_itself",
        stream(lambda folder: task(str(folder / FILE))),
        located("tasks[0].scenario"),
    ),
    Input("scenario_extends_cycle", stream(cycle), located("tasks[0].scenario", "cycle")),
    Input("scenario_dev_zero", stream(task("/dev/zero")), located("tasks[0].scenario")),
    Input(
        "scenario_fifo",
        stream(lambda folder: task(str(fifo(folder, "world.yaml")))),
        located("tasks[0].scenario"),
    ),
    Input("scenario_unknown", stream(task("fruitz")), located("tasks[0].scenario", "fruitz")),
    Input(
        "never_ending_scenario_unknown",
        stream("never_ending: {scenario: fruitz}\n"),
        located("never_ending.scenario", "fruitz"),
    ),
    Input(
        "overrides_bad",
        stream(task("fruits_poisons", ", overrides: {n_agents: -1}")),
        located("tasks[0].overrides"),
    ),
    Input(
        "focal_unknown",
        stream(task("fruits_poisons_multi", ", focal: [agent_9], background: idle")),
        located("tasks[0].focal[0]", "agent_9"),
    ),
    Input(
        "steps_zero",
        stream(task("fruits_poisons").replace("steps: 10", "steps: 0")),
        located("tasks[0].steps"),
    ),
    Input(
        "cycles_10_to_6", stream("cycles: 1000000\n" + task("fruits_poisons")), located("cycles")
    ),
    Input(
        "eval_every_zero",
        stream("eval: {every: 0}\n" + task("fruits_poisons")),
        located("eval.every"),
    ),
    Input(
        "not_utf8",
        lambda folder: ((folder / FILE).write_bytes(b"description: \xe9\n"), Snippet(LOAD))[1],
        located("", source=FILE),
    ),
    special("file_is_a_folder", lambda folder: (folder / FILE).mkdir()),
    special("file_is_a_fifo", lambda folder: fifo(folder, FILE)),
    special("file_is_dev_zero", lambda folder: (folder / FILE).symlink_to("/dev/zero")),
    special("file_sparse_2_gib", lambda folder: sparse(folder, FILE)),
    Input(
        "tasks_300",
        stream(
            "tasks:\n"
            + "".join(
                f"  - {{name: t{k}, scenario: fruits_poisons, steps: 10}}\n" for k in range(300)
            )
        ),
        located("tasks"),
    ),
    Input(
        "anchor_bomb",
        stream(
            'a: &a ["x","x","x","x","x","x","x","x","x"]\n'
            + "".join(
                f"{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n"
                for p, c in zip("abcdefgh", "bcdefghi")
            )
        ),
        bounded(),
    ),
]
