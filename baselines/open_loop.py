"""The open-loop baseline: a policy whose action depends only on the time step, never on
what the agent sees. A learned policy that does not beat it has learnt nothing a fixed
schedule of moves could not do (a lucky sweep of a room, a run at a wall).

For each seed, ``candidates`` sequences are drawn: each a schedule of actions, every
action drawn uniformly from the agent's action space and held for 1 to ``hold`` steps
(drawn uniformly), as long as an episode (each agent of a world its own schedule). Each
candidate plays ``episodes`` training episodes, reset with seeds apart from the held-out
ones and from every training world; the candidate with the best mean score is kept, and
it is then scored on the held-out episodes like every other method. It is a random search
over open-loop plans, "the Brute"'s idea (Machado et al., 2018) without the
determinism it needed: the episodes differ, so the plan that wins must do well across
worlds, not in one.
"""

from __future__ import annotations

import numpy as np

OPEN_LOOP_SEED = 500_000
"""Training episodes are reset with seeds from here on (a stream's task i from
``OPEN_LOOP_SEED + 1000 i``), apart from the held-out ones (100000 on; a stream's 1000000
on) and from PPO's worlds (``seed * num_envs + k``)."""
DEFAULT_LENGTH = 1000
"""The schedule's length in a world without a step limit (it then repeats)."""


class OpenLoopPolicy:
    """Plays ``schedule[t]`` at step t of an episode (repeating past its end); ``reset``
    starts it again. The observation is not read."""

    def __init__(self, schedule: list):
        if not schedule:
            raise ValueError("an open-loop schedule needs at least one action")
        self.schedule = schedule
        self.t = 0

    def reset(self) -> None:
        self.t = 0

    def act(self, observation):
        action = self.schedule[self.t % len(self.schedule)]
        self.t += 1
        return action


def schedule(space, length: int, hold: int, rng: np.random.Generator) -> list:
    """``length`` actions of ``space``: each drawn uniformly (the space seeded from
    ``rng``), held for 1 to ``hold`` steps."""
    if length < 1 or hold < 1:
        raise ValueError(f"a schedule needs length and hold of at least 1, not {length}, {hold}")
    space.seed(int(rng.integers(2**31)))
    out: list = []
    while len(out) < length:
        action = space.sample()
        out += [action] * int(rng.integers(1, hold + 1))
    return out[:length]


def candidates(env, agents: list[str], count: int, hold: int, seed: int) -> list[dict]:
    """``count`` candidates for ``agents`` of ``env``: each {agent: schedule}, drawn from
    ``seed``."""
    rng = np.random.default_rng([seed, 0x09E2])
    length = env.step_limit or DEFAULT_LENGTH
    return [
        {a: schedule(env.action_space(a), length, hold, rng) for a in agents} for _ in range(count)
    ]


def best_of(env, agents: list[str], play, config, seed: int, first_seed: int) -> tuple[dict, dict]:
    """The candidate (drawn from ``seed``) whose mean score over ``config.episodes``
    training episodes (reset with ``first_seed``, ``first_seed + 1``, ...) is highest:
    (its schedules by agent, a record of the search). ``play(policies, seeds)`` scores
    ``{agent: policy}`` on each episode seed; ties keep the first."""
    seeds = list(range(first_seed, first_seed + config.episodes))
    scores = []
    drawn = candidates(env, agents, config.candidates, config.hold, seed)
    for plan in drawn:
        policies = {a: OpenLoopPolicy(s) for a, s in plan.items()}
        scores.append(float(np.mean(play(policies, seeds))))
    best = int(np.argmax(scores))
    search = {
        "candidates": config.candidates,
        "training_episodes": config.episodes,
        "hold": config.hold,
        "best": best,
        "training_score": round(scores[best], 6),
        "training_scores": [round(s, 6) for s in scores],
    }
    return drawn[best], search
