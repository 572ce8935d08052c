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
  the goal of ``maze_goal``, ``key_door`` and ``switch_door``, fruits), Phi(s) = -d / 100,
  d the whole way the agent still has to walk to a paying thing: straight there, or, where
  a door is shut to it (locked without its key, shut until its switch is stepped on), by
  way of what opens it (the key, the switch; a key object: to it, then carrying it to the
  door) and on through the open door, whichever is shorter. The keys of shut doors are on
  the way, not ends of it, so Phi does not jump when the key is taken or the switch
  stepped on: the agent at the key is as far from the goal before it takes the key as
  after. A way is counted in steps of the shortest path over the episode's navigation grid
  (a diagonal step counts one) times the cell's width. Phi still jumps where a paying
  thing is used up and the next lies elsewhere (a fruit eaten, ``explore_goal``'s
  teleport): by at most the walk to the next, against the thing's reward. It reads the
  worlds themselves (zones and items are not in the global state), so it needs them in the
  learner's process (not ``--shards``).

``--shaping W`` picks the potential the scenario has (``--shaping-potential``: ``auto``,
delivery first, then goal; or either by name). ``--shaping-gamma G`` sets the term's own
discount, ``coef * (G Phi(s') - Phi(s))``: by default the learner's gamma, which keeps the
optimal policies but pays ``(1 - gamma) |Phi|`` every step for being far from the target
(with Phi of -2 to -4, more than the progress terms are noisy: on ``key_door`` it kept the
agent from the goal); 1, the plain progress made each step, which taught ``switch_door``,
``push_box`` and ``fetch_object`` where no shaping was paid rarely or never
(docs/results.md).
"""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.world.entities import Item, Obstacle
from flatland_ma.world.navigation import UNREACHED, NavGrid


def team_rewards(reward: np.ndarray, agents_per_world: int) -> np.ndarray:
    """Each slot's share of the team: the sum of its world's rewards, for every agent."""
    per_world = reward.reshape(-1, agents_per_world).sum(axis=1)
    return np.repeat(per_world, agents_per_world)


class DeliveryPotential:
    """Phi per slot of a batched env (see the module's docstring), read from the worlds'
    global state (``env.state()``). Each agent's zone is its team's where zones belong to
    teams (``tug_of_war``: each team shaped towards its own area), else the first zone
    that takes a delivery. Raises ``ValueError`` for a scenario without a zone that
    accepts a movable object's tag."""

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
        self.width, self.height = spec.arena.size
        m = env.agents_per_world
        names = env.possible_agents
        self.agents = []
        """Per agent: its x and y columns, its object's and its zone's rectangle."""
        for j, name in enumerate(names[:m]):
            team = spec.team_of(j)
            own = [p for p in pairs if team is not None and p[1].team == team.name]
            k, zone = (own or pairs)[0]
            self.agents.append(
                (
                    labels.index(f"{name}.x"),
                    labels.index(f"{name}.y"),
                    labels.index(f"object[{k}].x"),
                    labels.index(f"object[{k}].y"),
                    zone.rect,
                )
            )

    def read(self, env) -> np.ndarray:
        """Phi of each slot of ``env``, from its worlds' global state."""
        return self(env.state())

    def __call__(self, states: np.ndarray) -> np.ndarray:
        """Phi of each slot, from the worlds' states (one row per world)."""
        out = np.empty((len(states), len(self.agents)))
        for j, (ix, iy, jx, jy, (x0, y0, x1, y1)) in enumerate(self.agents):
            ox, oy = states[:, jx] * self.width, states[:, jy] * self.height
            to_zone = np.hypot(
                np.maximum(0, np.maximum(x0 - ox, ox - x1)),
                np.maximum(0, np.maximum(y0 - oy, oy - y1)),
            )
            to_object = np.hypot(states[:, ix] * self.width - ox, states[:, iy] * self.height - oy)
            out[:, j] = -(to_zone + to_object / 2) / 100.0
        return out.reshape(-1)


class GoalPotential:
    """Phi per slot of a batched env (see the module's docstring): minus the whole way the
    agent still has to walk to a paying thing, over 100. The paying things are the zones
    and the items that pay, less the keys of doors still shut to it; where a door in its
    way is shut (locked without its key, or shut until a switch opens it), the way may go
    by what opens it (the key, the switch, the key object carried to the door) and on
    from there through the open door. The
    fields are worked out again whenever a world's episode, the places of its paying
    things and keys, or the doors shut to an agent change (breadth-first searches over the
    episode's navigation grid). Raises ``ValueError`` for a scenario where nothing pays,
    or for worlds outside this process."""

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
        self.radii = [spec.agent_of(j).radius for j in range(self.agents)]
        """Each agent's radius: its ways are over the grid of where its centre fits."""
        self._fields: list[dict] = [{} for _ in worlds]
        """Each world's fields, by the doors shut to an agent (cleared with a new episode
        or new places of its paying things and keys)."""
        self._places: list[tuple | None] = [None] * len(worlds)
        self._seen: list[tuple | None] = [None] * len(worlds)
        """Each world's episode, its revision and its things when last read."""

    def read(self, env) -> np.ndarray:
        """Phi of each slot (the worlds are read, not ``env``'s global state)."""
        return self()

    def __call__(self, states: np.ndarray | None = None) -> np.ndarray:
        """Phi of each slot (``states`` is not read: the worlds are)."""
        out = np.empty((len(self.worlds), self.agents))
        for w, loop in enumerate(self.worlds):
            episode = loop.running
            things = self._things(w, episode)
            carried = [(o.key, o.body.position) for o in episode.world.of_type(Obstacle) if o.key]
            for j, body in enumerate(episode.bodies):
                keys = episode.task.records[j].keys
                shut = frozenset(d.index for d in episode.doors if d.blocks(keys))
                grid = episode.grid_for(self.radii[j])  # where this agent's centre fits
                fields, field = self._fields[w], (grid.clearance, shut)
                if field not in fields:
                    fields[field] = spread(self._way(episode, grid, things, shut))
                here = body.body.position
                steps = fields[field][grid.cell_of(*here)]
                for door in episode.doors:
                    for key, there in carried:
                        if door.index in shut and key == door.gate_key:
                            walk = math.dist(here, there) / grid.cell
                            carry = self._carry(w, episode, grid, things, shut, door)
                            steps = min(steps, walk + carry[grid.cell_of(*there)])
                if not math.isfinite(steps):  # no way it can open: as though the doors were
                    steps = self._open_way(w, episode, grid, things, here)
                out[w, j] = -steps * grid.cell / 100.0
        return out.reshape(-1)

    def _open_way(self, w: int, episode, grid, things: tuple, here) -> float:
        """Grid steps to a paying thing with every door open (an agent that cannot open the
        door in its way itself, such as ``plate_relay``'s runner, is led to it and waits
        there for another to open it), or, where even that finds nothing, the farthest
        way plus one."""
        fields, field = self._fields[w], (grid.clearance, frozenset())
        if field not in fields:
            fields[field] = spread(self._way(episode, grid, things, frozenset()))
        steps = fields[field][grid.cell_of(*here)]
        if math.isfinite(steps):
            return float(steps)
        finite = fields[field][np.isfinite(fields[field])]
        return finite.max() + 1.0 if finite.size else 0.0

    def _carry(self, w: int, episode, base, things: tuple, shut: frozenset, door) -> np.ndarray:
        """Grid steps from every cell of ``base`` to a paying thing by way of ``door``, for
        a key object there: carried to the door (until it touches it) and on through the
        open door."""
        fields, field = self._fields[w], (base.clearance, shut, door.index)
        if field not in fields:
            grid = self._shut_grid(episode, base, shut)
            after = self._way(episode, base, things, shut - {door.index})
            near = grid.shape_mask(door.shapes[0], extra=2 * grid.cell) & ~grid.blocked
            start = np.where(near, after, UNREACHED).astype(np.int32)
            fields[field] = spread(grid.distances_from(start))
        return fields[field]

    @staticmethod
    def _shut_grid(episode, base, shut: frozenset):
        grid = base.copy()
        for door in episode.doors:
            if door.index in shut:
                grid.block_shape(door.shapes[0])
        return grid

    def _things(self, w: int, episode) -> tuple:
        """World ``w``'s paying zones and items and its key items, as ``(rect, pays, key)``
        (``key``: the door key the item is, or None); the fields' cache is cleared when
        they, or the episode, changed. Items are static: they go, come back or move only
        through the world, which counts each change (``World.revision``)."""
        seen = self._seen[w]
        if seen is not None and seen[0] is episode and seen[1] == episode.world.revision:
            return seen[2]
        things = tuple((z.rect, z.reward > 0, None) for z in episode.world.zones)
        for item in episode.world.of_type(Item):
            if item.visible and (item.reward > 0 or item.group.key):
                (x, y), r = item.body.position, item.radius
                key = item.group.name if item.group.key else None
                things += (((x - r, y - r, x + r, y + r), item.reward > 0, key),)
        places = (id(episode), things)
        if self._places[w] != places:
            self._places[w] = places
            self._fields[w].clear()
        self._seen[w] = (episode, episode.world.revision, things)
        return things

    def _way(self, episode, base, things: tuple, shut: frozenset) -> np.ndarray:
        """Grid steps from every cell of ``base`` to a paying thing with the doors ``shut``
        shut: the least of walking straight there and of walking to what opens a shut door
        (its key, its switch) and on from there as though it were open (and its key
        taken)."""
        grid = self._shut_grid(episode, base, shut)
        openers = {d.gate_key for d in episode.doors if d.index in shut and d.gate_key}
        ends = [rect for rect, pays, key in things if pays and key not in openers]
        best = grid.distances(cells_of(grid, ends))
        zones = {z.name: z.rect for z in episode.world.zones}
        for door in episode.doors:
            if door.index not in shut:
                continue
            rects = [rect for rect, _, key in things if key is not None and key == door.gate_key]
            if door.switch in zones:
                rects.append(zones[door.switch])
            if not rects:
                continue
            opener = cells_of(grid, rects)
            taken = tuple(
                thing for thing in things if thing[2] is None or thing[2] != door.gate_key
            )
            after = self._way(episode, base, taken, shut - {door.index})
            start = np.where(opener, after, UNREACHED).astype(np.int32)
            best = np.minimum(best, grid.distances_from(start))
        return best


def cells_of(grid: NavGrid, rects) -> np.ndarray:
    """The mask of ``grid``'s cells in any of ``rects``."""
    mask = np.zeros_like(grid.blocked)
    for rect in rects:
        mask |= grid.cells_in(rect)
    return mask


def spread(distances: np.ndarray) -> np.ndarray:
    """Grid steps as floats where a blocked or unreached cell has none: a blocked cell (an
    agent pressed into a wall's clearance) takes its nearest free neighbour's steps plus
    one, spread a few cells deep; anything still unreached infinity."""
    ny, nx = distances.shape
    steps = distances.astype(np.float64)
    steps[distances == UNREACHED] = np.inf
    for _ in range(4):
        padded = np.pad(steps, 1, constant_values=np.inf)
        around = np.min(
            [
                padded[1 + di : 1 + di + ny, 1 + dj : 1 + dj + nx]
                for di in (-1, 0, 1)
                for dj in (-1, 0, 1)
            ],
            axis=0,
        )
        steps = np.minimum(steps, around + 1.0)
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
        self.last = self.potential.read(env)

    def __call__(self, env, terminated: np.ndarray) -> np.ndarray:
        now = self.potential.read(env)
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
    if args.team_reward:
        check_shared(env)
    shaping = (
        Shaping(potential_of(env, args.shaping_potential), args.shaping, shaping_gamma(args))
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


def check_shared(env) -> None:
    """``ValueError`` where the team reward (a world's summed reward) would teach nothing:
    a scenario whose teams score against each other (a zero-sum delivery), where the sum
    is 0 for every agent."""
    spec = env.spec
    against = [z.name for z in spec.zones if z.zero_sum and z.team]
    if against:
        raise ValueError(
            f"--team-reward sums every agent's reward in a world, but in {spec.source} the "
            f"teams score against each other (zero-sum zones {', '.join(against)}): the sum "
            "is 0 for every agent"
        )


def shaping_gamma(args) -> float:
    """The shaping term's discount: ``args.shaping_gamma``, or the learner's ``gamma``
    where that is below 0 (the default)."""
    gamma = getattr(args, "shaping_gamma", -1.0)
    if not math.isfinite(gamma) or gamma > 1.0:
        raise ValueError(f"shaping_gamma must be at most 1 (below 0: gamma), not {gamma}")
    return args.gamma if gamma < 0 else gamma


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
