"""A curriculum for ``baselines.ppo`` (``--curriculum FILE``): a stream file
(``flatland_ma.lifelong.streams``) whose tasks the run trains on in turn, every agent
learning in each, for each task's ``steps`` agent-steps (a stage ends with the first
rollout that ends after them); an easier version of a task
first (a lighter crate, a closer goal: the scenario's keyword overrides), then the task
itself. The run's log holds every stage's episodes; its JSON says at which agent-step each
stage began. Every stage must give the agents the spaces of the first (the stream's loader
checks it, through the padded space where a task's roles observe differently, as
``baselines.ppo`` pads them), since one network learns throughout.

A stage may name ``focal`` agents and a ``background`` policy (as a lifelong stream's
task does): then only the focal agents learn in it, and every other agent plays the named
shipped policy, for instance a scripted guide that tells the truth while the seeker learns
to listen, before a stage where every agent learns. The background policies get the
padded observation of their slot: those that read the world (``Signaller``) play as in
their own scenario.
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
    focal: tuple[int, ...] | None = None
    """The indices of the agents that learn in this stage (None: every agent)."""
    background: str | None = None
    """The shipped policy every other agent plays (with ``focal``)."""


def curriculum_stages(path: str | Path) -> list[Stage]:
    """The stages of the stream file at ``path``, over all its cycles, in order."""
    # baselines.ppo pads roles' observations, and one network sits in every slot
    stream = load_stream(Path(path), padded=True, every_slot=True)
    if stream.never_ending:
        raise ValueError(f"{path}: a curriculum needs tasks, not the never-ending mode")
    stages = []
    for index, start, end in stream.segments():
        task = stream.task(index)
        focal = None if task.focal is None else tuple(stream.focal(index))
        stages.append(
            Stage(task.name, stream.scenarios[index], end - start, focal, task.background)
        )
    return stages
