"""PPO for policies with memory (``--memory gru``, ``--frames K``): a rollout that keeps
what each slot remembered when it began, and an update that replays it.

The policy (``baselines.networks.Agent``, ``flatland_ma.policies.memory``) carries each
slot's memory from step to step and across rollouts; a slot's memory restarts at the
first step of its episode. With the batched env's NEXT_STEP resets that step is the one
where the slot acts again after a step in which it did not (its world was being reset);
every slot's first step after the env's reset is one too. The rollout stores, besides
what ``baselines.ppo_learner.Rollout`` stores:

- ``starts`` (T, slots): whether each step began its slot's episode;
- ``initial``: each slot's recurrent state before the rollout's first step;
- with ``frames: K``, the K - 1 frames of each slot's stack before the first step, kept
  before the rollout's own frames, so that every step's stack is rebuilt from single
  frames (``policies.memory.stack_indices``) rather than stored K times.

The update (CleanRL's ``ppo_atari_lstm``): with a recurrent core, each minibatch is a set
of slots (``num_minibatches`` parts of the slots, at most one slot each), whose whole
sequences are replayed from ``initial`` with the state restarted at ``starts``, so step t
of the replay reads the state the policy acted from (until the first gradient step moves
the weights); only the steps where the env used the slot's action enter the loss. With
frames alone, minibatches are of steps, as without memory, each with its stack.
"""

from __future__ import annotations

import numpy as np
import torch
from torch.utils._pytree import tree_leaves, tree_map

from baselines.networks import Agent
from baselines.ppo_learner import Rollout
from baselines.ppo_loss import descend
from flatland_ma.policies.memory import Memory, each, gather_stacks, stack_indices


class MemoryRollout(Rollout):
    """``Rollout`` for an ``Agent`` with memory: the same ``collect`` (its ``begin``,
    ``decide`` and ``bootstrap`` carry the memory) and its own ``learn`` (not
    for ``Overlapped``, whose two rollouts would have to hand the memory on)."""

    def __init__(self, agent: Agent, env, observation, steps: int):
        super().__init__(agent, env, observation, steps)
        self.k = k = agent.frames
        frames = tree_map(
            lambda x: np.zeros((k - 1 + steps, *x.shape[1:]), x.dtype), self._observations
        )
        self.frames = tree_map(torch.from_numpy, frames)
        """The K - 1 frames of each slot's stack before the rollout, then its T frames."""
        self._observations = tree_map(lambda x: x[k - 1 :], frames)
        self.observations = tree_map(lambda x: x[k - 1 :], self.frames)
        self.views = [tree_map(lambda x, t=t: x[t], self.observations) for t in range(steps)]
        self.starts = torch.zeros((steps, env.num_slots))
        self.previous_acting = np.zeros(env.num_slots, bool)
        """Whether the env used each slot's action on the step before."""
        self.memory: Memory | None = None
        """Each slot's memory after the last step acted (None: before the first)."""
        self.initial = torch.zeros((env.num_slots, agent.memory_size))
        """Each slot's recurrent state before the rollout's first step."""
        self.index: torch.Tensor | None = None
        """With frames, where each step's stack lies in ``frames`` (``stack_indices``)."""
        self._env = env

    def _begin(self, env) -> bool:
        """Keep what each slot remembered before the rollout; whether its memory is new
        (a run's first rollout, or a curriculum's new worlds)."""
        if env is not self._env:
            self._env, self.memory = env, None
        if self.memory is None:
            self.initial.zero_()
            return True
        if self.memory.hidden is not None:
            self.initial = self.memory.hidden.clone()
        if self.k > 1:
            for before, stack in zip(tree_leaves(self.frames), tree_leaves(self.memory.frames)):
                before[: self.k - 1] = stack[:, 1:].transpose(0, 1)
        return False

    def begin(self, env) -> None:
        self.fresh = self._begin(env)

    def decide(self, agent: Agent, t: int, state):
        """The step's action, each slot's memory carried on from its last step (and
        restarted where the slot acts again after its world's reset)."""
        acting = self.next_acting.copy()
        self.starts[t] = torch.from_numpy(acting & ~self.previous_acting)
        if self.fresh and t == 0:
            self.starts[0] = 1.0
        self.previous_acting = acting
        h, self.memory = agent.step(self.views[t], self.memory, self.starts[t])
        action, logprob, _, value = agent.decide(h, state=state, generator=self.generator)
        return action, logprob, value

    def bootstrap(self, agent: Agent, observation, state) -> torch.Tensor:
        """The value of what the last step returned, read with each slot's memory (which
        the next rollout's first step moves on from again)."""
        starts = torch.from_numpy(self.next_acting & ~self.previous_acting)
        h, _ = agent.step(tree_map(torch.from_numpy, observation), self.memory, starts)
        return agent.critic(h if state is None else state).squeeze(-1)

    def learn(self, agent: Agent, optimizer, args, penalty=None, generator=None) -> dict:
        """GAE bootstrapped from the value of what the rollout's last step returned, then
        PPO's epochs over sequences of slots (with a recurrent core) or over steps, the
        minibatches drawn from ``generator``."""
        advantages = self.advantages(args)
        if self.k > 1:
            self.index = stack_indices(self.starts, self.k)
        returns = advantages + self.values
        return update(agent, optimizer, args, self, advantages, returns, penalty, generator)

    def stacks(self, steps: torch.Tensor, slots: torch.Tensor):
        """What the network read at each (step, slot) of these (n,) pairs: the
        observation, or with frames its stack (n, K, ...)."""
        if self.index is None:  # rows of (T * slots): into the kept buffers
            rows = steps * self.acting.shape[1] + slots
            return self.gather(each(lambda x: x.flatten(0, 1), self.observations), rows)
        return gather_stacks(self.frames, self.index[steps, slots], slots)

    def minibatches(self, agent: Agent, parts: int, generator=None):
        """``parts`` minibatches of the steps the env used, drawn from ``generator``: for
        each, what the heads read at those steps (with the current weights) and the steps'
        flat indices into (T * slots)."""
        steps, slots = self.acting.shape
        if agent.core is None:
            used = self.acting.reshape(-1).nonzero().squeeze(1)
            order = used[torch.randperm(len(used), generator=generator)]
            for entries in order.tensor_split(parts):
                yield agent.features(self.stacks(entries // slots, entries % slots)), entries
            return
        for group in torch.randperm(slots, generator=generator).tensor_split(min(parts, slots)):
            used = self.acting[:, group]
            if not used.any():
                continue
            t = torch.arange(steps).repeat_interleave(len(group))
            inputs = self.stacks(t, group.repeat(steps))
            shape = (steps, len(group))
            inputs = each(lambda x, shape=shape: x.unflatten(0, shape), inputs)
            h = agent.replay(inputs, self.initial[group], self.starts[:, group])
            entries = torch.arange(steps).unsqueeze(1) * slots + group
            yield h[used], entries[used]


def update(
    agent: Agent,
    optimizer,
    args,
    rollout: MemoryRollout,
    advantages,
    returns,
    penalty=None,
    generator=None,
):
    """PPO's epochs over ``rollout.minibatches``; the last epoch's mean losses (as
    ``baselines.ppo_learner.update``)."""

    def flat(x: torch.Tensor) -> torch.Tensor:
        return x.reshape(-1, *x.shape[2:])

    actions, logprobs, values = flat(rollout.actions), flat(rollout.logprobs), flat(rollout.values)
    advantages, returns = flat(advantages), flat(returns)
    states = None if rollout.states is None else flat(rollout.states)
    stats: dict[str, list[float]] = {}
    for epoch in range(args.update_epochs):
        for h, entries in rollout.minibatches(agent, args.num_minibatches, generator):
            state = None if states is None else states[entries]
            _, new_logprob, entropy, new_value = agent.decide(h, actions[entries], state)
            old = (logprobs[entries], advantages[entries], returns[entries], values[entries])
            parts = descend(agent, optimizer, args, (new_logprob, entropy, new_value), old, penalty)
            if epoch == args.update_epochs - 1:
                for key, value in parts.items():
                    stats.setdefault(key, []).append(float(value))
    return {key: float(np.mean(values)) for key, values in stats.items()}
