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

A stage may end early, on what the learner does in it (``until: {mean_return: R,
episodes: N}``): once the learner's last N episodes in the stage average a return of at
least R (its own, unshaped), the next stage begins with the next rollout, and the steps the
stage did not use go to the stages after it; the run's budget stays the stages' sum, the
last stage running to it. A stage so gated lasts at most its ``steps``. The run's JSON says
where each stage began and whether it ended on its ``until``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatland_ma.lifelong.envs import policies_beside
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
    until: float | None = None
    """The mean return of the learner's latest ``over`` episodes that ends the stage early
    (None: it lasts its steps)."""
    over: int = 100
    """How many of the stage's latest episodes ``until`` is the mean of."""

    def reached(self, returns: Sequence[float]) -> bool:
        """Whether the stage's latest episode returns end it early (never before ``over``
        of them, never without ``until``)."""
        if self.until is None or len(returns) < self.over:
            return False
        return float(np.mean(list(returns)[-self.over :])) >= self.until


def curriculum_stages(path: str | Path) -> list[Stage]:
    """The stages of the stream file at ``path``, over all its cycles, in order."""
    # baselines.ppo pads roles' observations, and one network sits in every slot
    stream = load_stream(Path(path), padded=True, every_slot=True, curriculum=True)
    if stream.never_ending:
        raise ValueError(f"{path}: a curriculum needs tasks, not the never-ending mode")
    stages = []
    for index, start, end in stream.segments():
        task = stream.task(index)
        focal = None if task.focal is None else tuple(stream.focal(index))
        gate = task.until
        stages.append(
            Stage(
                task.name,
                stream.scenarios[index],
                end - start,
                focal,
                task.background,
                until=None if gate is None else gate.mean_return,
                over=100 if gate is None else gate.episodes,
            )
        )
    return stages


def stage_ends(stages: Sequence[Stage], began: Sequence[int]) -> np.ndarray:
    """The agent-step at which each stage's steps run out, given where the stages so far
    began (``began``): the stages' steps in turn, less, for every stage after one that
    ended early, the steps that stage left unused. A stage that ends on its steps ends with
    the first rollout after them, and the next stage's end is unmoved by that overshoot."""
    ends = np.cumsum([stage.steps for stage in stages])
    for k in range(len(began) - 1):
        unused = int(ends[k]) - int(began[k + 1])
        if unused > 0:
            ends[k + 1 :] -= unused
    return ends


def stages_record(stages: Sequence[Stage], began: Sequence[int]) -> list[dict]:
    """The run's JSON of its curriculum: each stage's name and the agent-step it began at,
    its ``until`` if it has one, and, for each stage the run went past, whether it ended
    early (on its ``until``) rather than on its steps."""
    ends, record = stage_ends(stages, began), []  # a stage's end rests on earlier starts only
    for k, (stage, step) in enumerate(zip(stages, began)):
        entry: dict = {"name": stage.name, "began": int(step)}
        if stage.until is not None:
            entry["until"] = stage.until
        if k + 1 < len(began):
            entry["ended_early"] = bool(began[k + 1] < ends[k])
        record.append(entry)
    return record


def partner_policies(env, stage: Stage | None, seed: int) -> dict[int, object]:
    """A curriculum stage's background policy at every slot that does not learn in it,
    built for that slot's world (empty without a background)."""
    if stage is None or stage.background is None or stage.focal is None:
        return {}
    m, rng = env.agents_per_world, np.random.default_rng([seed, 2])
    return {
        w * m + world.possible_agents.index(agent): policy
        for w, world in enumerate(env.worlds)
        for agent, policy in policies_beside(stage.background, world, stage.focal, rng).items()
    }
