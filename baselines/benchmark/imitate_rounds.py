"""What the imitation probe (``baselines.benchmark.imitate``) keeps of its rounds and how
it learns from them: a feed-forward network from every step kept (``Kept``, ``train``); a
network with memory (``--memory gru``) from rounds played slot by slot, each slot's steps
of a round kept as one sequence, taught on pieces of those sequences replayed from the
state it reaches there (``collect_sequences``, ``train_sequences``).

A round begins every world anew, so each slot's sequence begins an episode; the slot's
memory restarts wherever its world was reset (``starts``), while acting as in training.
Each epoch first replays every sequence whole, without gradients and with the epoch's
first weights, for the state at the beginning of each piece of ``sequence`` steps; the
minibatches are then pieces (``batch // sequence`` of them), their gradients cut at the
piece's first step (truncated backpropagation through time from a state that is exact for
the weights the epoch began with, as R2D2's stored states are for the weights that acted).
Only the steps where the slot's agent acted enter the loss.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import torch
from torch.utils._pytree import tree_map

from baselines.networks import Agent, action_sizes


class Kept:
    """Every step kept so far, in arrays made once for all the rounds' steps (one copy of
    the data: a map of 64 x 64 pixels is 49 kB a step)."""

    def __init__(self, capacity: int):
        self.capacity, self.count = capacity, 0
        self.views = None
        self.labels = None

    def add(self, views: list, labels: list) -> None:
        if self.views is None:
            self.views = tree_map(
                lambda x: np.empty((self.capacity, *np.shape(x)), np.asarray(x).dtype), views[0]
            )
            self.labels = np.empty((self.capacity, len(labels[0])), np.int64)
        start, end = self.count, self.count + len(labels)
        for row, view in enumerate(views, start):
            tree_map(lambda buffer, x, row=row: buffer.__setitem__(row, x), self.views, view)
        assert self.labels is not None
        self.labels[start:end] = labels
        self.count = end

    def arrays(self):
        """The views and labels kept (views of the arrays, no copy)."""
        assert self.labels is not None
        return tree_map(lambda x: x[: self.count], self.views), self.labels[: self.count]


def train(network: Agent, optimizer, views, labels: np.ndarray, args, rng) -> float:
    """``args.epochs`` passes of cross-entropy on the solver's actions; the mean loss of
    the last."""
    losses: list[float] = []
    for _ in range(args.epochs):
        losses = []
        order = rng.permutation(len(labels))
        for start in range(0, len(order), args.batch):
            rows = order[start : start + args.batch]
            batch = tree_map(lambda x, rows=rows: torch.from_numpy(x[rows]), views)
            _, logprob, _, _ = network.act(batch, torch.from_numpy(labels[rows]))
            losses.append(descend(optimizer, -logprob.mean()))
    return float(np.mean(losses))


class Sequence(NamedTuple):
    """One round's steps, slot by slot: arrays of (T, slots, ...)."""

    views: Any
    """What the network reads, as ``imitate.Worlds.view`` gives it."""
    labels: np.ndarray
    """The solver's action (T, slots, heads); 0 where the agent did not act."""
    starts: np.ndarray
    """Whether the step began the slot's episode (T, slots)."""
    used: np.ndarray
    """Whether the slot's agent acted at the step (T, slots)."""


def slots_of(worlds) -> list[tuple[int, str]]:
    """Every imitating agent of every world: (world, agent), the sequences' columns."""
    return [(w, a) for w in range(len(worlds.envs)) for a in worlds.imitating]


def round_length(worlds, steps: int, sequence: int) -> int:
    """Steps a round plays: at least ``steps`` of every slot together, in whole pieces."""
    per_slot = -(-steps // len(slots_of(worlds)))
    return -(-per_slot // sequence) * sequence


def collect_sequences(worlds, network: Agent | None, steps: int, base: int, sequence: int):
    """As ``imitate.collect``, played for ``round_length`` steps with every slot's memory
    carried from step to step (restarted at its episode's first step): the round's
    ``Sequence``, the returns of the episodes that ended in it, and how often the
    network's actions were the solver's."""
    slots = slots_of(worlds)
    length = round_length(worlds, steps, sequence)
    observations = [worlds.reset(w, base) for w in range(len(worlds.envs))]
    totals = [dict.fromkeys(worlds.agents, 0.0) for _ in worlds.envs]
    began = np.ones(len(slots), bool)
    last: dict[int, Any] = {}
    rows: dict[str, list] = {"views": [], "labels": [], "starts": [], "used": []}
    returns: list[float] = []
    agreed: list[bool] = []
    memory = None
    for _ in range(length):
        actions, views, labels, used = _solver_step(worlds, slots, observations, last)
        if network is not None:
            batch = tree_map(lambda *xs: torch.from_numpy(np.stack(xs)), *views)
            with torch.inference_mode():
                h, memory = network.step(batch, memory, torch.from_numpy(began))
                drawn = network.decide(h)[0].numpy()
            for k, (w, a) in enumerate(slots):
                if used[k]:
                    agreed.append(bool(np.array_equal(drawn[k], labels[k])))
                    actions[w][a] = drawn[k] if np.ndim(actions[w][a]) else int(drawn[k][0])
        for key, value in zip(rows, (views, labels, began.copy(), used), strict=True):
            rows[key].append(value)
        began = np.zeros(len(slots), bool)
        for w in step_worlds(worlds, observations, actions, totals, returns, base):
            began[[k for k, (v, _) in enumerate(slots) if v == w]] = True
    each_step = [tree_map(lambda *v: np.stack(v), *views) for views in rows["views"]]
    stacked = Sequence(
        tree_map(lambda *xs: np.stack(xs), *each_step),
        np.stack([np.stack(labels) for labels in rows["labels"]]),
        np.stack(rows["starts"]),
        np.stack(rows["used"]),
    )
    return {
        "sequence": stacked,
        "returns": returns,
        "agreement": float(np.mean(agreed)) if agreed else None,
    }


def _solver_step(worlds, slots, observations, last: dict):
    """One step's actions (the solver's for imitating agents, random play's for the
    rest), each slot's view (its last one where its agent no longer acts), label and
    whether it acted."""
    actions: list[dict] = [{} for _ in worlds.envs]
    views, labels, used = [], [], []
    idle = np.zeros(len(action_sizes(worlds.action_space)), np.int64)  # one label a head
    for k, (w, a) in enumerate(slots):
        if a in worlds.envs[w].agents:
            expert = worlds.experts[w][a].act(observations[w][a])
            actions[w][a] = expert
            last[k] = worlds.view(a, observations[w][a])
            labels.append(np.atleast_1d(np.asarray(expert, np.int64)))
            used.append(True)
        else:
            labels.append(idle)
            used.append(False)
        views.append(last[k])
    for w, env in enumerate(worlds.envs):
        for a in env.agents:
            if a not in worlds.imitating:
                actions[w][a] = worlds.random[w][a].act(observations[w][a])
    return actions, views, labels, np.array(used)


def piece_states(network: Agent, kept: list[Sequence], sequence: int) -> list[torch.Tensor]:
    """For each kept round, the recurrent state before each piece's first step
    (pieces, slots, memory_size), from replaying every slot's sequence whole."""
    out = []
    with torch.no_grad():
        for seq in kept:
            length, slots = seq.starts.shape
            columns = []
            for s in range(slots):
                views = tree_map(lambda x, s=s: torch.from_numpy(x[:, s : s + 1]), seq.views)
                starts = torch.from_numpy(seq.starts[:, s : s + 1])
                h = network.replay(views, torch.zeros(1, network.memory_size), starts)[:, 0]
                before = torch.cat([h.new_zeros(1, h.shape[1]), h[:-1]])
                columns.append(before[::sequence])
            out.append(torch.stack(columns, 1))
    return out


def train_sequences(network: Agent, optimizer, kept: list[Sequence], args, rng) -> float:
    """``args.epochs`` passes of cross-entropy on the solver's actions over pieces of the
    kept sequences; the mean loss of the last."""
    losses: list[float] = []
    n = args.sequence
    per = max(1, args.batch // n)
    for _ in range(args.epochs):
        states = piece_states(network, kept, n)
        pieces = [
            (r, c, s)
            for r, seq in enumerate(kept)
            for c in range(0, seq.starts.shape[0], n)
            for s in range(seq.starts.shape[1])
            if seq.used[c : c + n, s].any()
        ]
        order = rng.permutation(len(pieces))
        losses = []
        for start in range(0, len(order), per):
            group = [pieces[i] for i in order[start : start + per]]
            views, labels, starts, used = _pieces(kept, group, n)
            initial = torch.stack([states[r][c // n, s] for r, c, s in group])
            h = network.replay(views, initial, starts)
            _, logprob, _, _ = network.decide(h[used], labels[used])
            losses.append(descend(optimizer, -logprob.mean()))
    return float(np.mean(losses))


def _pieces(kept: list[Sequence], group: list[tuple[int, int, int]], n: int):
    """The views, labels, starts and used steps of these pieces (round, first step, slot),
    side by side: (n, pieces, ...)."""

    def side(field: str) -> torch.Tensor:
        parts = [getattr(kept[r], field)[c : c + n, s] for r, c, s in group]
        return torch.from_numpy(np.stack(parts, 1))

    views = tree_map(
        lambda *xs: torch.from_numpy(np.stack(xs, 1)),
        *[tree_map(lambda x, c=c, s=s: x[c : c + n, s], kept[r].views) for r, c, s in group],
    )
    return views, side("labels"), side("starts"), side("used")


def step_worlds(worlds, observations: list, actions: list, totals: list, returns: list, base: int):
    """Step every world with its actions, adding each agent's rewards to ``totals``; a
    world whose episode ended has its imitating agents' mean return added to ``returns``
    and is reset (``observations`` and ``totals`` updated in place). The worlds reset."""
    reset = []
    for w, env in enumerate(worlds.envs):
        observations[w], rewards, *_ = env.step(actions[w])
        for a, r in rewards.items():
            totals[w][a] += float(r)
        if not env.agents:
            returns.append(float(np.mean([totals[w][a] for a in worlds.imitating])))
            totals[w] = dict.fromkeys(worlds.agents, 0.0)
            observations[w] = worlds.reset(w, base)
            reset.append(w)
    return reset


def descend(optimizer, loss: torch.Tensor) -> float:
    """One gradient step on ``loss``; its value."""
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
    return loss.item()
