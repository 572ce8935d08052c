"""What PPO learns from, beside the scenario's own reward: the team's reward and a
potential-based shaping term. Neither changes what the run logs (the scenario's return).

- ``team_rewards``: every agent of a world learns from the sum of its world's rewards, so
  the helper that holds the door or lifts the other end of the crate is paid as the one
  who scores.
- ``DeliveryPotential``: for scenarios where a movable object is delivered into a zone
  (``coop_carry``, ``push_box``), Phi(s) = -(d(object, zone) + d(agent, object) / 2) / 100,
  in world units (the object's distance to the zone's rectangle, 0 inside, and the agent's
  to the object). The learner adds ``coef * (gamma Phi(s') - Phi(s))`` to each agent's
  reward, with Phi = 0 after the episode terminates. Shaping of this form leaves the
  optimal policies unchanged (Ng, Harada and Russell, "Policy invariance under reward
  transformations", 1999): over an episode it sums to -Phi(s_0), whatever the agents do.
"""

from __future__ import annotations

import math

import numpy as np


def team_rewards(reward: np.ndarray, agents_per_world: int) -> np.ndarray:
    """Each slot's share of the team: the sum of its world's rewards, for every agent."""
    per_world = reward.reshape(-1, agents_per_world).sum(axis=1)
    return np.repeat(per_world, agents_per_world)


class DeliveryPotential:
    """Phi per slot of a batched env (see the module's docstring), read from the worlds'
    global state (``env.state()``). Raises ``ValueError`` for a scenario without a zone
    that accepts a movable object's tag."""

    def __init__(self, env):
        world = env.worlds[0] if hasattr(env, "worlds") else None
        spec = env.spec if world is None else world.spec
        labels = world.state_labels if world is not None else env.state_labels
        zones = [z for z in spec.zones if z.accepts is not None]
        movable = [o for o in spec.obstacles if getattr(o, "movable", False)]
        pairs = [
            (k, zone) for zone in zones for k, o in enumerate(movable) if o.tag == zone.accepts
        ]
        if not pairs:
            raise ValueError(
                f"{spec.name if hasattr(spec, 'name') else 'this scenario'} delivers nothing "
                "(no zone accepts a movable object's tag): delivery shaping needs one"
            )
        k, zone = pairs[0]
        self.width, self.height = spec.arena.size
        self.rect = zone.rect
        self.object = (labels.index(f"object[{k}].x"), labels.index(f"object[{k}].y"))
        m = env.agents_per_world
        names = env.possible_agents
        self.agents = [(labels.index(f"{n}.x"), labels.index(f"{n}.y")) for n in names[:m]]

    def __call__(self, states: np.ndarray) -> np.ndarray:
        """Phi of each slot, from the worlds' states (one row per world)."""
        x0, y0, x1, y1 = self.rect
        ox = states[:, self.object[0]] * self.width
        oy = states[:, self.object[1]] * self.height
        to_zone = np.hypot(
            np.maximum(0, np.maximum(x0 - ox, ox - x1)), np.maximum(0, np.maximum(y0 - oy, oy - y1))
        )
        out = np.empty((len(states), len(self.agents)))
        for j, (ix, iy) in enumerate(self.agents):
            to_object = np.hypot(states[:, ix] * self.width - ox, states[:, iy] * self.height - oy)
            out[:, j] = -(to_zone + to_object / 2) / 100.0
        return out.reshape(-1)


class Shaping:
    """The shaping term of each step, ``coef * (gamma Phi(s') - Phi(s))`` per slot, with
    Phi(s') = 0 where the slot's episode terminated. A world reset between two steps
    gives its slots a meaningless term on the step after the end; the learner leaves
    those steps out (their slots do not act)."""

    def __init__(self, potential: DeliveryPotential, coef: float, gamma: float):
        self.potential, self.coef, self.gamma = potential, coef, gamma
        self.last: np.ndarray | None = None

    def start(self, env) -> None:
        self.last = self.potential(env.state())

    def __call__(self, env, terminated: np.ndarray) -> np.ndarray:
        now = self.potential(env.state())
        assert self.last is not None, "call start() after the env's reset"
        term = self.coef * (self.gamma * np.where(terminated, 0.0, now) - self.last)
        self.last = now
        return term

    @staticmethod
    def check(coef: float) -> None:
        if not math.isfinite(coef) or coef < 0:
            raise ValueError(f"shaping must be a finite weight >= 0, not {coef}")


def learning_reward(args, env):
    """What the rollout learns from, given the step's reward and terminations: the
    reward, the team's (``team_reward``), plus the shaping term (``shaping``); None
    when it is the reward itself."""
    if not (args.team_reward or args.shaping):
        return None
    Shaping.check(args.shaping)
    shaping = Shaping(DeliveryPotential(env), args.shaping, args.gamma) if args.shaping else None
    if shaping is not None:
        shaping.start(env)
    m = env.agents_per_world

    def learn_from(reward, terminated):
        out = team_rewards(reward, m) if args.team_reward else reward
        return out if shaping is None else out + shaping(env, terminated)

    return learn_from
