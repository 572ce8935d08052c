"""Can PPO's network read a task's answer from what an agent sees? A supervised probe.

A task is fair to a learner only if what it must know is in its observations in a form a
network can read. This probe asks that apart from reinforcement learning: it resets the
scenario at ``episodes`` seeds, labels each episode with the room that holds the goal
(the rooms a channel's words name: the zones that pay nothing, in order; the goal is the
item that pays most; episodes whose goal lies in no room are left out), and trains
``baselines.ppo``'s own network (its encoders and hidden layer, a head of one logit per
room) to tell the room from the agent's first observation, by cross-entropy on four
fifths of the episodes. It reports the accuracy on the other fifth, held out, beside
chance (the commonest room's share), epoch by epoch.

A held-out accuracy near chance says the observation does not show the answer in a way
this network learns from this many examples; near 1, that it does, and a learner that
does not use it fails for another reason (credit, exploration, budget). On
``signal_rooms`` version 1, whose guide's map turned with the guide, 3,200 first maps
taught the network nothing that held (54% at best on 800 held out, chance 51%, while it
learnt the 3,200 by heart); held north up (version 2), 99%.

    python -m baselines.benchmark.readout --scenario signal_rooms --agent guide_0
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import tyro
from gymnasium import spaces
from torch.utils._pytree import tree_map

import flatland_ma
from baselines.common import input_channels
from baselines.networks import Agent
from flatland_ma.policies.signals import room_holding, rooms_of
from flatland_ma.world.entities import Item


@dataclass
class Args:
    scenario: str = "signal_rooms"
    """The scenario (a shipped name or a file)."""
    agent: str = "guide_0"
    """Whose first observation is read."""
    episodes: int = 4000
    """Episodes (seeds 0 on), a fifth of them held out."""
    epochs: int = 15
    """Passes over the training episodes."""
    batch: int = 64
    learning_rate: float = 3e-4
    hidden: int = 128
    use_depth: bool = False
    seed: int = 0
    json: str = ""
    """Also write the figures to this JSON file."""


def goal_zone(env) -> int | None:
    """The index of the room (``rooms_of``: the zones words name) that holds the
    episode's goal (the visible item that pays most), or None if none does."""
    items = [i for i in env.episode.world.of_type(Item) if i.visible and i.reward > 0]
    if not items:
        return None
    return room_holding(rooms_of(env.spec), max(items, key=lambda i: i.reward).body.position)


@dataclass
class Episodes:
    """Each labelled episode's first observation (an array, or a dict of arrays, rows
    first) and its goal's zone; the agent's observation space and the zones' names."""

    observations: np.ndarray | dict[str, np.ndarray]
    labels: np.ndarray
    space: spaces.Space
    zones: list[str]

    def rows(self, index: torch.Tensor):
        """The observations of episodes ``index``, as the network reads them."""
        return tree_map(lambda x: torch.from_numpy(x[index.numpy()]), self.observations)


def first_observations(args: Args) -> Episodes:
    """The first observation of ``args.agent`` and the goal's zone in every episode whose
    goal lies in a zone."""
    env = flatland_ma.parallel_env(args.scenario)
    if args.agent not in env.possible_agents:
        raise ValueError(f"{args.agent!r} is no agent of {args.scenario}: {env.possible_agents}")
    rooms = rooms_of(env.spec)
    if len(rooms) < 2:
        raise ValueError(f"{args.scenario} has {len(rooms)} rooms (zones that pay nothing)")
    space = env.observation_space(args.agent)
    rows, labels = [], []
    for seed in range(args.episodes):
        observations, _ = env.reset(seed=seed)
        zone = goal_zone(env)
        if zone is not None:
            rows.append(observations[args.agent])
            labels.append(zone)
    env.close()
    stacked = tree_map(lambda *xs: np.stack(xs), *rows)
    names = [
        z.name or f"room {k}" for k, z in enumerate(z for z in env.spec.zones if z.rect in rooms)
    ]
    return Episodes(stacked, np.array(labels, np.int64), space, names)


def probe(args: Args) -> dict:
    """Train the probe; the figures: chance, and each epoch's loss and accuracies."""
    torch.manual_seed(args.seed)
    episodes = first_observations(args)
    y, zones = torch.from_numpy(episodes.labels), len(episodes.zones)
    if len(y) < 10:
        raise ValueError(f"{len(y)} episodes with the goal in a zone: too few to probe")
    network = Agent(
        episodes.space, spaces.Discrete(zones), args.hidden, input_channels(args.use_depth)
    )
    generator = torch.Generator().manual_seed(args.seed)
    order = torch.randperm(len(y), generator=generator)
    cut = len(y) * 4 // 5
    train, held = order[:cut], order[cut:]
    chance = float(torch.bincount(y[held], minlength=zones).max()) / len(held)
    optimizer = torch.optim.Adam(network.parameters(), lr=args.learning_rate)

    def accuracy(rows: torch.Tensor) -> float:
        with torch.no_grad():
            guessed = network.actor(network.features(episodes.rows(rows))).argmax(-1)
        return float((guessed == y[rows]).float().mean())

    epochs = []
    for epoch in range(args.epochs):
        shuffled, losses = train[torch.randperm(cut, generator=generator)], []
        for start in range(0, cut, args.batch):
            rows = shuffled[start : start + args.batch]
            logits = network.actor(network.features(episodes.rows(rows)))
            loss = torch.nn.functional.cross_entropy(logits, y[rows])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            losses.append(loss.item())
        epochs.append(
            {
                "epoch": epoch,
                "loss": float(np.mean(losses)),
                "train": accuracy(train),
                "held_out": accuracy(held),
            }
        )
    return {
        "scenario": args.scenario,
        "agent": args.agent,
        "episodes": len(y),
        "zones": episodes.zones,
        "chance": chance,
        "epochs": epochs,
    }


def main(args: Args) -> dict:
    figures = probe(args)
    print(
        f"{figures['scenario']}, {figures['agent']}'s first observation -> the goal's zone "
        f"({', '.join(figures['zones'])}); {figures['episodes']} episodes, chance "
        f"{figures['chance']:.2f}"
    )
    for row in figures["epochs"]:
        print(
            f"  epoch {row['epoch']:>3}  loss {row['loss']:.3f}  train {row['train']:.3f}  "
            f"held out {row['held_out']:.3f}"
        )
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return figures


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
