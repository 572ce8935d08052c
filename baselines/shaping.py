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
- ``GoalPotential``: for scenarios whose reward waits somewhere (``explore_goal``'s zone,
  the goal of ``maze_goal`` and ``switch_door``, ``key_door``'s key, fruits), Phi(s) =
  -d / 100, d the agent's walking distance to its nearest target: a zone or an item in
  view that pays, or the switch of a door still shut; round the doors in its way (locked
  without its key, shut until switched), as the scripted planner goes. The distance is the
  steps of the shortest path over the episode's navigation grid (a diagonal step counts
  one) times the cell's width. Phi jumps when a target is used up (the key taken, the next
  target the goal beyond the door), and the agent is charged the jump at once: where the
  jump can exceed the target's reward (``key_door``, ``switch_door``), the agent learns to
  leave the target alone (docs/results.md); use it where targets pay more, or weigh it
  less. It reads the worlds themselves (zones and items are not in the global state), so
  it needs them in the learner's process (not ``--shards``).

``--shaping W`` picks the potential the scenario has (``--shaping-potential``: ``auto``,
delivery first, then goal; or either by name).
"""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.policies.planner import round_doors
from flatland_ma.world.entities import Item
from flatland_ma.world.navigation import UNREACHED, NavGrid


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


class GoalPotential:
    """Phi per slot of a batched env (see the module's docstring): minus the walking
    distance to the agent's next target, over 100. The targets are the zones and the items
    in view that pay, and the switch zones of doors still shut; the way goes round the
    doors that stop this agent (locked without its key, or shut until a switch opens them),
    as the scripted planner plans. The distances are worked out again whenever a world's
    episode, the places of its paying things or the doors in an agent's way change (a
    breadth-first search over the episode's navigation grid). Raises ``ValueError`` for a
    scenario where nothing pays, or for worlds outside this process."""

    def __init__(self, env):
        worlds = getattr(env, "worlds", None)
        if worlds is None:
            raise ValueError(
                "goal shaping reads the worlds themselves: run them in the learner's process "
                "(no --shards)"
            )
        spec = worlds[0].spec
        if not any(thing.reward > 0 for thing in (*spec.zones, *spec.items)):
            raise ValueError(
                f"{spec.source}: no zone or item pays a reward (goal shaping walks to one)"
            )
        self.worlds = worlds
        self.agents = env.agents_per_world
        self._fields: list[dict] = [{} for _ in worlds]
        """Each world's distances, by what they depend on (cleared with a new episode or
        new places of its paying things)."""
        self._places: list[tuple | None] = [None] * len(worlds)

    def __call__(self, states: np.ndarray | None = None) -> np.ndarray:
        """Phi of each slot (``states`` is not read: the worlds are)."""
        out = np.empty((len(self.worlds), self.agents))
        for w, loop in enumerate(self.worlds):
            episode = loop.running
            rects = self._targets(w, episode)
            grid = episode.grid
            for j, body in enumerate(episode.bodies):
                distances = self._field(w, episode, rects, j)
                x, y = body.body.position
                out[w, j] = -distances[grid.cell_of(x, y)] * grid.cell / 100.0
        return out.reshape(-1)

    def _targets(self, w: int, episode) -> tuple:
        """The rectangles of world ``w``'s paying zones and items (its cache cleared when
        they, or the episode, changed)."""
        rects = tuple(z.rect for z in episode.world.zones if z.reward > 0)
        for item in episode.world.of_type(Item):
            if item.visible and item.reward > 0:
                (x, y), r = item.body.position, item.radius
                rects += ((x - r, y - r, x + r, y + r),)
        places = (id(episode), rects)
        if self._places[w] != places:
            self._places[w] = places
            self._fields[w].clear()
        return rects

    def _field(self, w: int, episode, rects: tuple, j: int) -> np.ndarray:
        """Agent ``j``'s distances in grid steps: round the doors in its way, to the paying
        things and the switches of shut doors."""
        keys = episode.task.records[j].keys
        closed = tuple(d.index for d in episode.doors if d.blocks(keys))
        switches = {d.switch for d in episode.doors if d.switch and not d.is_open}
        targets = rects + tuple(z.rect for z in episode.world.zones if z.name in switches)
        fields = self._fields[w]
        if (closed, targets) not in fields:
            grid = round_doors(episode.grid, episode.doors, keys)
            fields[(closed, targets)] = walking_steps(grid, targets)
        return fields[(closed, targets)]


def walking_steps(grid: NavGrid, rects) -> np.ndarray:
    """Grid steps from every cell to the nearest of ``rects``, as floats: a blocked cell
    (an agent pressed into a wall's clearance) takes its nearest free neighbour's steps
    plus one, spread a few cells deep; anything still unreached the farthest reached
    distance plus one."""
    mask = np.zeros((grid.ny, grid.nx), np.bool_)
    for rect in rects:
        mask |= grid.cells_in(rect)
    steps = grid.distances(mask).astype(np.float64)
    steps[steps == UNREACHED] = np.inf
    for _ in range(4):
        padded = np.pad(steps, 1, constant_values=np.inf)
        around = np.min(
            [
                padded[1 + di : 1 + di + grid.ny, 1 + dj : 1 + dj + grid.nx]
                for di in (-1, 0, 1)
                for dj in (-1, 0, 1)
            ],
            axis=0,
        )
        steps = np.minimum(steps, around + 1.0)
    finite = np.isfinite(steps)
    steps[~finite] = (steps[finite].max() + 1.0) if finite.any() else 0.0
    return steps


class Shaping:
    """The shaping term of each step, ``coef * (gamma Phi(s') - Phi(s))`` per slot, with
    Phi(s') = 0 where the slot's episode terminated. A world reset between two steps
    gives its slots a meaningless term on the step after the end; the learner leaves
    those steps out (their slots do not act)."""

    def __init__(self, potential, coef: float, gamma: float):
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
    shaping = (
        Shaping(potential_of(env, args.shaping_potential), args.shaping, args.gamma)
        if args.shaping
        else None
    )
    if shaping is not None:
        shaping.start(env)
    m = env.agents_per_world

    def learn_from(reward, terminated):
        out = team_rewards(reward, m) if args.team_reward else reward
        return out if shaping is None else out + shaping(env, terminated)

    return learn_from


POTENTIALS = ("auto", "delivery", "goal")
"""What ``--shaping-potential`` takes."""


def potential_of(env, kind: str = "auto"):
    """The shaping potential ``kind`` names for ``env``'s scenario; ``auto``: delivery
    where a zone takes deliveries, else goal (each raises ``ValueError`` where it has
    nothing to measure)."""
    if kind == "delivery":
        return DeliveryPotential(env)
    if kind == "goal":
        return GoalPotential(env)
    if kind != "auto":
        raise ValueError(f"shaping_potential must be one of {', '.join(POTENTIALS)}, not {kind!r}")
    try:
        return DeliveryPotential(env)
    except ValueError as delivery:
        try:
            return GoalPotential(env)
        except ValueError as goal:
            raise ValueError(f"nothing to shape towards: {delivery}; {goal}") from None
