"""The mechanics of ``baselines.ppo``: a rollout of every slot of a batched env, GAE, PPO's
epochs over it, and collection overlapped with the update.

Written for speed as well as for the maths, since the learner must keep up with the world:

- observations are stored in the dtype the env gives them (a map of ``uint8`` stays
  ``uint8``: four times less memory to write and read), and the network casts on reading;
- the acting pass samples from the logits directly (``baselines.networks.Agent``), not
  through ``torch.distributions``;
- GAE is one compiled loop (numba) over the rollout;
- freed memory stays with the process between minibatches (``keep_freed_memory``): glibc
  otherwise returns the large activations' pages to the system after each one and takes
  them back, page fault by page fault, for the next;
- each minibatch's observations are gathered into buffers kept from one minibatch to the
  next (``Gather``): a minibatch of maps can be larger than any block glibc keeps, and
  would otherwise come in fresh pages every time;
- ``Overlapped`` collects the next rollout with a copy of the policy while the network
  updates on the previous one, in a thread of its own (torch releases Python's lock while
  it computes): a policy lag of one update, as APPO's and Sample Factory's.
"""

from __future__ import annotations

import copy
import threading
import time
from contextlib import contextmanager

import gymnasium
import numba as nb
import numpy as np
import torch
from torch.utils._pytree import tree_leaves, tree_map

from baselines.buffers import Gather
from baselines.networks import Agent
from baselines.ppo_loss import descend
from flatland_ma.envs.vector import slot_observation


@nb.njit(cache=True)
def _gae(rewards, values, ends, stops, next_value, gamma, lam):  # pragma: no cover - compiled
    steps, slots = rewards.shape
    advantages = np.empty_like(rewards)
    last = np.zeros(slots, dtype=rewards.dtype)
    for t in range(steps - 1, -1, -1):
        for s in range(slots):
            following = next_value[s] if t == steps - 1 else values[t + 1, s]
            delta = rewards[t, s] + gamma * following * (1.0 - stops[t, s]) - values[t, s]
            last[s] = delta + gamma * lam * (1.0 - ends[t, s]) * last[s]
            advantages[t, s] = last[s]
    return advantages


def gae(rewards, values, ends, stops, next_value, gamma: float, lam: float) -> torch.Tensor:
    """Generalised advantage estimation per slot over a rollout of T steps:
        delta_t = r_t + gamma V(s_{t+1}) (1 - terminated_t) - V(s_t)
        A_t = delta_t + gamma lambda (1 - ended_t) A_{t+1}
    where s_{t+1} is what step t returned: after a truncation, the episode's last
    observation (NEXT_STEP autoreset), so the cut episode bootstraps from its value."""
    arrays = (x.numpy() for x in (rewards, values, ends, stops, next_value))
    return torch.from_numpy(_gae(*arrays, np.float32(gamma), np.float32(lam)))


@contextmanager
def critic_only(agent, on: bool = True):
    """While ``on``, every parameter of ``agent`` but its critic head's is held: it takes
    no gradient, so the optimiser leaves it (and the policy) as it is."""
    if not on:
        yield
        return
    critic = {id(p) for p in agent.critic.parameters()}
    held = [p for p in agent.parameters() if p.requires_grad and id(p) not in critic]
    for p in held:
        p.requires_grad_(False)
    try:
        yield
    finally:
        for p in held:
            p.requires_grad_(True)


def update(
    agent,
    optimizer,
    args,
    acting,
    observations,
    actions,
    logprobs,
    advantages,
    returns,
    values,
    penalty=None,
    states=None,
    generator: torch.Generator | None = None,
    gather: Gather | None = None,
    bias=None,
) -> dict:
    """CleanRL's PPO epochs over the rollout's acting entries; returns the last epoch's
    mean losses. The loss is ``baselines.ppo_loss``'s [+ ``penalty()``] [+ the channel's
    ``bias``, a ``baselines.channel_bias.ChannelBias``], with V read from ``states``
    where the critic is centralised. Minibatches are drawn from ``generator`` (torch's
    global one if None), their observations gathered by ``gather`` (a new ``Gather`` if
    None)."""
    gather = Gather() if gather is None else gather
    used = acting.reshape(-1).nonzero().squeeze(1)
    b_states = None if states is None else states.reshape(-1, states.shape[-1])
    b_x = tree_map(lambda x: x.reshape(-1, *x.shape[2:]), observations)
    b_actions, b_logprobs = actions.reshape(-1, actions.shape[-1]), logprobs.reshape(-1)
    b_advantages, b_returns, b_values = (
        advantages.reshape(-1),
        returns.reshape(-1),
        values.reshape(-1),
    )
    stats: dict[str, list[torch.Tensor]] = {}
    for epoch in range(args.update_epochs):
        order = used[torch.randperm(len(used), generator=generator)]
        # num_minibatches parts of (nearly) equal size: no leftover part of one entry.
        for index in order.tensor_split(args.num_minibatches):
            x = gather(b_x, index)
            state = None if b_states is None else b_states[index]
            extra, terms = None, {}
            if bias is None:
                decided = agent.act(x, b_actions[index], state)
            else:
                decided, extra, terms = bias.act(agent, x, b_actions[index], state, index)
            old = (b_logprobs[index], b_advantages[index], b_returns[index], b_values[index])
            parts = descend(agent, optimizer, args, decided[1:], old, penalty, extra)
            parts.update(terms)
            if epoch == args.update_epochs - 1:
                for key, value in parts.items():
                    stats.setdefault(key, []).append(value)
    return {key: float(torch.stack(values).mean()) for key, values in stats.items()}


class Rollout:
    """T steps of every slot of a batched env: what the policy saw and did, and what came
    of it; ``collect`` fills it, ``learn`` runs PPO's epochs over it."""

    def __init__(self, agent: Agent, env, observation, steps: int):
        T, slots = steps, env.num_slots
        self.steps = steps
        # Every buffer is a numpy array and a tensor over the same memory: the step loop
        # writes through numpy (a row costs well under a microsecond; through a tensor's
        # indexing, several), the update reads the tensors.
        self._observations = tree_map(lambda x: np.zeros((T, *np.shape(x)), x.dtype), observation)
        self.observations = tree_map(torch.from_numpy, self._observations)
        """The raw observations, as the env gives them (a dict of arrays for a Dict space),
        in the env's own dtype."""
        self.views = [tree_map(lambda x, t=t: x[t], self.observations) for t in range(T)]
        """Step t's observations, as views."""
        self._actions = np.zeros((T, slots, len(agent.sizes)), np.int64)
        self.discrete = isinstance(env.single_action_space, gymnasium.spaces.Discrete)
        self._logprobs, self._rewards, self._values, self._ends, self._stops = (
            np.zeros((T, slots), np.float32) for _ in range(5)
        )
        self._acting = np.zeros((T, slots), bool)
        self.actions = torch.from_numpy(self._actions)
        self.logprobs, self.rewards, self.values = (
            torch.from_numpy(x) for x in (self._logprobs, self._rewards, self._values)
        )
        self.acting = torch.from_numpy(self._acting)
        """Whether the env used the slot's action on that step."""
        self.ends, self.stops = torch.from_numpy(self._ends), torch.from_numpy(self._stops)
        """Whether the slot's episode ended on that step (terminated or truncated), and
        whether it terminated (no bootstrap)."""
        self.next_acting = np.ones(slots, bool)
        """Whether the env will use each slot's next action."""
        self.states = torch.zeros((T, slots, agent.state_size)) if agent.state_size else None
        """Each slot's critic input (``slot_states``) when the critic is centralised."""
        self.next_value = torch.zeros(slots)
        """The value of what the rollout's last step returned, for GAE's bootstrap."""
        self.env_seconds = 0.0
        self.generator: torch.Generator | None = None
        """Where the acting pass draws its actions from (torch's global one if None)."""
        self.learns = np.ones(slots, bool)
        """The slots that learn; the others act at random from ``background`` (or play
        their ``partners``' policy) and are left out of the update and of the agent-steps
        counted (``--learners``, a curriculum's ``focal``)."""
        self.partners: dict[int, object] = {}
        """A shipped policy for each slot that does not learn, by slot (a curriculum's
        ``background``): it acts there instead of random play."""
        self.background = np.random.default_rng(0)
        self._sizes = np.array(agent.sizes, np.int64)
        self.gather = Gather()
        """Where the update's minibatches of observations are gathered, kept from one
        update to the next."""
        self.bias = None
        """The channel's biases added to the update's loss (``baselines.channel_bias``;
        None: none)."""
        self.novelty = None
        """An exploration bonus added to the rewards learnt from (``baselines.novelty``)."""
        self.final = None
        """What the rollout's last step returned, kept for ``novelty``."""

    def collect(
        self, agent: Agent, env, observation, reward_scale: float, after_step, learn_from=None
    ):
        """Act for ``steps`` steps from ``observation``; after each,
        ``after_step(reward, terminated, done, infos, acted)`` with ``acted`` the number
        of slots whose action the env used. The rollout keeps
        ``learn_from(reward, terminated) * reward_scale`` (the reward itself when
        ``learn_from`` is None). Returns the last observation."""
        self.begin(env)
        stored = tree_leaves(self._observations)
        others = ~self.learns if not self.learns.all() else None  # slots acting at random
        for t in range(self.steps):
            for into, x in zip(stored, tree_leaves(observation)):
                into[t] = x
            self._acting[t] = self.next_acting & self.learns
            state = None
            if self.states is not None:
                self.states[t] = state = torch.from_numpy(slot_states(env))
            with torch.no_grad():
                action, logprob, value = self.decide(agent, t, state)
            chosen = self._actions[t]
            chosen[:] = action.numpy()
            if others is not None:
                chosen[others] = self.background.integers(self._sizes, size=chosen[others].shape)
            if self.partners:
                self._partner_actions(chosen, observation)
            self._logprobs[t], self._values[t] = logprob.numpy(), value.numpy()
            tick = time.perf_counter()
            observation, reward, terminated, truncated, infos = env.step(
                chosen[:, 0] if self.discrete else chosen
            )
            self.env_seconds += time.perf_counter() - tick
            done = terminated | truncated
            if self.partners and done.any():
                self._partners_restart(done)
            learnt = reward if learn_from is None else learn_from(reward, terminated)
            self._rewards[t] = learnt * reward_scale
            self._ends[t], self._stops[t] = done, terminated
            after_step(reward, terminated, done, infos, int(self._acting[t].sum()))
            # The env uses a slot's action next step unless it just finished or was inert.
            self.next_acting = infos["active"] & ~done
        next_state = None if self.states is None else torch.from_numpy(slot_states(env))
        with torch.no_grad():
            self.next_value = self.bootstrap(agent, observation, next_state)
        if self.novelty is not None:  # a copy: the env writes its next step over its own
            self.final = tree_map(np.copy, observation)
        return observation

    def _partner_actions(self, chosen: np.ndarray, observation) -> None:
        """Each partner's action at its slot, where the env uses it: the policy sees its
        slot's observation as the batched env gives it."""
        for slot, policy in self.partners.items():
            if not self.next_acting[slot]:
                continue
            chosen[slot] = np.asarray(policy.act(slot_observation(observation, slot))).reshape(-1)

    def _partners_restart(self, done: np.ndarray) -> None:
        """A partner whose slot's episode ended starts its next one afresh."""
        for slot in np.flatnonzero(done):
            reset = getattr(self.partners.get(int(slot)), "reset", None)
            if reset is not None:
                reset()

    # What a rollout of a policy with memory (baselines.ppo_memory) does its own way.

    def begin(self, env) -> None:
        """Before the rollout's first step (nothing to keep without memory)."""

    def decide(self, agent: Agent, t: int, state):
        """The action, its log-probability and the value at step ``t``, whose
        observations are in ``views[t]``."""
        action, logprob, _, value = agent.act(self.views[t], state=state, generator=self.generator)
        return action, logprob, value

    def bootstrap(self, agent: Agent, observation, state) -> torch.Tensor:
        """The value of what the rollout's last step returned."""
        return agent.value(tree_map(torch.from_numpy, observation), state)

    def advantages(self, args) -> torch.Tensor:
        """GAE over the rollout, bootstrapped from ``next_value``, with ``novelty``'s
        bonus added to the rewards (and its predictor trained) if there is one."""
        rewards = self.rewards
        if self.novelty is not None:
            rewards = rewards + self.novelty.bonus(self.observations, self.final, self.acting)
        return gae(
            rewards,
            self.values,
            self.ends,
            self.stops,
            self.next_value,
            args.gamma,
            args.gae_lambda,
        )

    def learn(self, agent: Agent, optimizer, args, penalty=None, generator=None) -> dict:
        """GAE, bootstrapped from the value of what the rollout's last step returned (by
        the policy that acted), then PPO's epochs (``update``) with minibatches drawn from
        ``generator``, and ``penalty()`` added to the loss if given."""
        advantages = self.advantages(args)
        return update(
            agent,
            optimizer,
            args,
            self.acting,
            self.observations,
            self.actions,
            self.logprobs,
            advantages,
            advantages + self.values,
            self.values,
            penalty,
            self.states,
            generator,
            self.gather,
            self.bias,
        )


class Overlapped:
    """Collection and update at once: while ``agent`` learns from one rollout in a thread
    of its own, ``collect`` fills the other with ``behaviour``, a copy of the parameters
    from before that update (a lag of one update). The draws of actions and of minibatches
    come from generators of their own, so a run is the same whatever the threads'
    timing."""

    def __init__(self, agent: Agent, env, observation, steps: int, seed: int):
        self.behaviour = copy.deepcopy(agent)
        self.behaviour.requires_grad_(False)
        self.rollouts = [Rollout(agent, env, observation, steps) for _ in range(2)]
        self.acting_generator = torch.Generator().manual_seed(seed)
        self.update_generator = torch.Generator().manual_seed(seed + 1)
        for rollout in self.rollouts:
            rollout.generator = self.acting_generator
        self.turn = 0
        self.pending: threading.Thread | None = None
        self.stats: dict = {}
        self.error: BaseException | None = None
        self.update_seconds = 0.0

    @property
    def env_seconds(self) -> float:
        return sum(rollout.env_seconds for rollout in self.rollouts)

    def collect(self, env, observation, reward_scale, after_step, learn_from=None):
        """The next rollout, from ``behaviour``, while the previous one's update runs."""
        rollout = self.rollouts[self.turn]
        rollout.next_acting = self.rollouts[1 - self.turn].next_acting
        return rollout.collect(
            self.behaviour, env, observation, reward_scale, after_step, learn_from
        )

    @property
    def next_acting(self) -> np.ndarray:
        """Whether the env will use each slot's next action (after the last rollout)."""
        return self.rollouts[1 - self.turn].next_acting

    def learn(self, agent: Agent, optimizer, args, penalty=None) -> dict:
        """Wait for the update under way, start one on the rollout just collected, and
        return the statistics of the one that finished (empty at the first call)."""
        self.wait()
        stats, self.stats = self.stats, {}
        rollout = self.rollouts[self.turn]
        self.turn = 1 - self.turn

        def run() -> None:
            tick = time.thread_time()
            try:
                self.stats = rollout.learn(
                    agent, optimizer, args, penalty=penalty, generator=self.update_generator
                )
            except BaseException as error:  # raised again in the collecting thread
                self.error = error
            self.update_seconds += time.thread_time() - tick

        # The next rollout acts with the parameters from before this update.
        self.behaviour.load_state_dict(agent.state_dict())
        self.pending = threading.Thread(target=run, name="ppo-update", daemon=True)
        self.pending.start()
        return stats

    def wait(self) -> None:
        """Let the update under way finish (raising what it raised)."""
        if self.pending is not None:
            self.pending.join()
            self.pending = None
        if self.error is not None:
            error, self.error = self.error, None
            raise error


def slot_states(env) -> np.ndarray:
    """Each slot's input to a centralised critic: its world's global state
    (``env.state()``, one row per world) and a one-hot of which agent of the world it is."""
    m = env.agents_per_world
    states = np.repeat(env.state(), m, axis=0)
    who = np.tile(np.eye(m, dtype=np.float32), (env.num_worlds, 1))
    return np.concatenate([states, who], axis=1, dtype=np.float32)
