"""Does a trained pair use its channel? The guide's first word and the seeker beside
other guides.

On a signalling task (a guide that sees where the goal is and a seeker that does not:
the scenario's reference solver names them ``signaller`` and ``follower``), a checkpoint
plays the seeker beside four guides on the same episodes: the checkpoint's own guide,
the scripted ``Signaller`` (its word names the goal's room), random words (the
``Signaller``'s moves, a word drawn at random each step) and a liar (the ``Signaller``
with its word turned to another room); then the checkpoint's guide beside the scripted
``Heeder`` (which goes to the room named most often), the guide's half alone. For each
it reports the episodes' mean return, how often the guide's first word named the goal's
room (``readout.goal_zone``) and the share of all its words that did.

A seeker that listens scores more beside the truthful guide than beside random words,
and less beside the liar; a guide that tells says the right words more often than
chance, and the ``Heeder`` beside it scores more than beside random words. Scores alike
beside all four say the channel is not used, whatever the return.

    python -m baselines.benchmark.listening runs/ppo/signal_rooms/seed_0.safetensors
"""

from __future__ import annotations

import argparse

import numpy as np

from baselines.benchmark.readout import goal_zone
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.checkpoint import CheckpointPolicy, read_checkpoint
from flatland_ma.policies.scores_header import solver_names
from flatland_ma.policies.signals import Heeder, Signaller


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


def word(action) -> int:
    """The word of a guide's action (its last component)."""
    return int(np.asarray(action).reshape(-1)[-1])


def play(env, policies: dict, guide: str, seeds) -> tuple[float, float, float]:
    """(the mean return per agent, the share of episodes whose guide's first word named
    the goal's room, the share of all the guide's words that did) over episodes reset
    with ``seeds``."""
    returns, told, words = [], [], []
    for seed in seeds:
        observations, _ = env.reset(seed=int(seed))
        for policy in policies.values():
            getattr(policy, "reset", lambda: None)()
        zone, total, said = goal_zone(env), 0.0, []
        while env.agents:
            actions = {a: policies[a].act(observations[a]) for a in env.agents}
            if guide in actions:
                said.append(word(actions[guide]) == zone)
            observations, rewards, *_ = env.step(actions)
            total += float(np.mean(list(rewards.values())))
        returns.append(total)
        told.append(said[0])
        words += said
    return float(np.mean(returns)), float(np.mean(told)), float(np.mean(words))


def check(checkpoint: str, episodes: int = 40, first_seed: int = 500) -> dict:
    """The seeker of ``checkpoint`` beside each guide, then its guide beside the
    ``Heeder``: {pair: (return, first word true, words true)}."""
    env = FlatlandParallelEnv(read_checkpoint(checkpoint)["scenario"])
    try:
        guide, seeker = roles(env)
        guides = {  # beside the checkpoint's seeker
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
        policies = {
            guide: CheckpointPolicy.for_agent(checkpoint, env, guide, seed=2),
            seeker: Heeder(env, seeker, seed=1),
        }
        out["its own guide, the Heeder seeking"] = play(env, policies, guide, seeds)
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
    for name, (score, told, words) in figures.items():
        print(
            f"  {name:>33}: return {score:6.2f}, the guide's first word names the room "
            f"{told:.0%}, its words {words:.0%}"
        )
    return figures


if __name__ == "__main__":
    main()
