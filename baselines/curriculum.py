"""A curriculum for ``baselines.ppo`` (``--curriculum FILE``): a stream file
(``flatland_ma.lifelong.streams``) whose tasks the run trains on in turn, every agent
learning in each, for each task's ``steps`` agent-steps (a stage ends with the first
rollout that ends after them); an easier version of a task
first (a lighter crate, a closer goal: the scenario's keyword overrides), then the task
itself. The run's log holds every stage's episodes; its JSON says at which agent-step each
stage began. Every stage must give the agents the spaces of the first (the stream's loader
checks it, through the padded space where a task's roles observe differently, as
``baselines.ppo`` pads them), since one network learns throughout.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from flatland_ma.lifelong.streams import load_stream
from flatland_ma.scenario.schema import ScenarioSpec


@dataclass(frozen=True)
class Stage:
    name: str
    spec: ScenarioSpec
    """The task's scenario with its overrides, loaded and checked."""
    steps: int
    """Agent-steps of training in this stage."""


def curriculum_stages(path: str | Path) -> list[Stage]:
    """The stages of the stream file at ``path``, over all its cycles, in order."""
    stream = load_stream(Path(path), padded=True)  # baselines.ppo pads roles' observations
    if stream.never_ending:
        raise ValueError(f"{path}: a curriculum needs tasks, not the never-ending mode")
    stages = []
    for index, start, end in stream.segments():
        task = stream.task(index)
        if task.focal is not None or task.background is not None:
            raise ValueError(
                f"{path}: task {task.name!r} names focal agents or a background policy; "
                "in a curriculum every agent learns"
            )
        stages.append(Stage(task.name, stream.scenarios[index], end - start))
    return stages
