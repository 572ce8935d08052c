"""Does a trained pair use its channel? The guide's first word and the seeker beside
other guides.

On a signalling task (a guide that sees where the goal is and a seeker that does not:
the scenario's reference solver names them ``signaller`` and ``follower``), a checkpoint
plays the seeker beside four guides on the same episodes: the checkpoint's own guide,
the scripted ``Signaller`` (its word names the goal's room), random words (the
``Signaller``'s moves, a word drawn at random each step) and a liar (the ``Signaller``
with its word turned to another room). For each it reports the episodes' mean return and
how often the guide's first word named the goal's room (``readout.goal_zone``).

A seeker that listens scores more beside the truthful guide than beside random words,
and less beside the liar; a guide that tells says the right first word more often than
chance. Scores alike beside all four say the channel is not used, whatever the return.

    python -m baselines.benchmark.listening runs/ppo/signal_rooms/seed_0.safetensors
"""

from __future__ import annotations

import argparse

import numpy as np

from baselines.benchmark.readout import goal_zone
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.checkpoint import CheckpointPolicy, read_checkpoint
from flatland_ma.policies.scores_header import solver_names
from flatland_ma.policies.signals import Signaller


class RandomWords(Signaller):
    """The ``Signaller``'s moves, with a word drawn at random each step."""

    def __init__(self, env, agent: str, seed: int = 0):
        super().__init__(env, agent)
        self.rng = np.random.default_rng(seed)
        self.vocabulary = int(env.spec.channel.vocabulary)

    def act(self, observation=None):
        action = np.array(super().act(observation))
        action[-1] = self.rng.integers(self.vocabulary)
        return action


class Liar(Signaller):
    """The ``Signaller`` with its word turned to the next room (another one)."""

    def act(self, observation=None):
        action = np.array(super().act(observation))
        action[-1] = (action[-1] + 1) % int(self.env.spec.channel.vocabulary)
        return action


def roles(env) -> tuple[str, str]:
    """(the guide, the seeker): the agents the reference solver plays as ``signaller``
    and ``follower``."""
    names = solver_names(env)
    by_role = {
        role: [a for a, n in names.items() if n == role] for role in ("signaller", "follower")
    }
    if len(by_role["signaller"]) != 1 or len(by_role["follower"]) != 1:
        raise ValueError(
            f"the reference solver plays no one guide (signaller) and one seeker "
            f"(follower): {names}"
        )
    return by_role["signaller"][0], by_role["follower"][0]


def first_word(action) -> int:
    return int(np.asarray(action).reshape(-1)[-1])


def play(env, policies: dict, guide: str, seeds) -> tuple[float, float]:
    """(the mean return per agent, the share of episodes whose guide's first word named
    the goal's room) over episodes reset with ``seeds``."""
    returns, told = [], []
    for seed in seeds:
        observations, _ = env.reset(seed=int(seed))
        for policy in policies.values():
            getattr(policy, "reset", lambda: None)()
        zone, total, first = goal_zone(env), 0.0, True
        while env.agents:
            actions = {a: policies[a].act(observations[a]) for a in env.agents}
            if first:
                told.append(first_word(actions[guide]) == zone)
                first = False
            observations, rewards, *_ = env.step(actions)
            total += float(np.mean(list(rewards.values())))
        returns.append(total)
    return float(np.mean(returns)), float(np.mean(told))


def check(checkpoint: str, episodes: int = 40, first_seed: int = 500) -> dict:
    """The seeker of ``checkpoint`` beside each guide: {guide: (return, first word true)}."""
    env = FlatlandParallelEnv(read_checkpoint(checkpoint)["scenario"])
    try:
        guide, seeker = roles(env)
        guides = {
            "its own guide": lambda: CheckpointPolicy.for_agent(checkpoint, env, guide, seed=2),
            "Signaller": lambda: Signaller(env, guide),
            "random words": lambda: RandomWords(env, guide),
            "liar": lambda: Liar(env, guide),
        }
        seeds = range(first_seed, first_seed + episodes)
        out = {}
        for name, make in guides.items():
            policies = {
                guide: make(),
                seeker: CheckpointPolicy.for_agent(checkpoint, env, seeker, seed=1),
            }
            out[name] = play(env, policies, guide, seeds)
    finally:
        env.close()
    return out


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("checkpoint")
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--first-seed", type=int, default=500)
    args = parser.parse_args(argv)
    figures = check(args.checkpoint, args.episodes, args.first_seed)
    for name, (score, told) in figures.items():
        print(f"  beside {name:>13}: return {score:6.2f}, first word names the room {told:.0%}")
    return figures


if __name__ == "__main__":
    main()
