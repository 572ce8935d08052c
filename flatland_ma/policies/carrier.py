"""A scripted solver for object tasks (privileged: it reads the env's state).

It finds its job: a key object to bring to the locked door it opens, or a tagged object
to bring into a zone that rewards its team. An agent with a grasper walks (on the
occupancy grid) to the side of the object away from where it must go, faces it, walks into
it with its hand closed, then heads for the destination with the object held ahead. An
agent without one stands behind the object and pushes it along the line to the
destination, stepping round to get behind again when it slides off. Agents on one object
take sides spread around it, so that several can carry together. With no job left (the
door is open), it plays on with ``PlannerPolicy``.

It drives discrete bodies (any head and arms); with several graspers it carries with the
one whose arm points most nearly ahead.
"""

from __future__ import annotations

import math

from flatland_ma.agents.grasp import Grasper
from flatland_ma.build.bodies import make_parts
from flatland_ma.policies.planner import PlannerPolicy, descend, mask_at, wrap_angle
from flatland_ma.world.entities import Obstacle

SIDE_SPREAD = math.radians(70)
"""Angle between the sides that agents sharing one object take around it."""
ARRIVED = 6.0
"""Distance to a waypoint that counts as being there."""


class CarrierPolicy:
    def __init__(self, env, agent: str):
        self.env = env
        self.agent = agent
        self.index = env.possible_agents.index(agent)
        self.fallback = PlannerPolicy(env, agent)
        spec = env.spec
        body = spec.agent_of(self.index)
        if body.actions != "discrete":
            raise ValueError(
                "CarrierPolicy drives discrete bodies only (agent.actions: discrete); "
                f"this scenario's agents act through {env.action_space(agent)}"
            )
        names = env.action_names(agent)
        self.ids = {name: names.index(name) for name in names}
        self.turn_step = math.radians(body.max_turn_rate) * spec.physics.dt
        self.radius = body.radius
        arm, self.hand, grip = _carrying_arm(body)
        self.reach = sum(s.length for s in arm.segments) if arm else 0.0
        # How far its longest arm reaches: kept off the object while walking round it.
        self.span = max((sum(s.length for s in a.segments) for a in body.arms), default=0.0)
        if grip is not None:  # that hand's actions, e.g. "arm1_grasp" with several hands
            self.ids["grasp"], self.ids["release"] = (self.ids[name] for name in grip)
        team = spec.team_of(self.index)
        self.team = team.name if team else None

    def reset(self) -> None:
        self.fallback.reset()

    def act(self, observation=None):
        episode = self.env.episode
        job = self._job(episode)
        me = episode.bodies[self.index]
        hand = me.hands[self.hand] if self.hand is not None else None
        if job is None:
            if hand is not None and hand.closed:
                return self.ids["release"]  # done with it: let go before moving on
            return self.fallback.act(observation)
        thing, destination = job
        if hand is not None:
            if hand.held is thing:
                # Carrying together, turning against the others' pull gets stuck: only
                # turn when far off course.
                together = sum(self._shares(i) for i in range(len(episode.bodies))) > 1
                return self._steer(me, destination, math.radians(45) if together else None)
            return self._fetch(episode, me, hand, thing, destination)
        return self._push(episode, me, thing, destination)

    # -- what to do ---------------------------------------------------------------------

    def _job(self, episode):
        for door in episode.doors:
            if not door.is_open and door.gate_key is not None:
                for thing in _objects(episode):
                    if thing.key == door.gate_key:
                        return thing, _door_centre(door)
        for thing in _objects(episode):
            for zone in episode.world.zones:
                mine = zone.team is None or zone.team == self.team
                if zone.accepts == thing.tag and mine and zone.delivery_reward > 0:
                    return thing, zone.centre
        return None

    # -- grasping and carrying ----------------------------------------------------------

    def _fetch(self, episode, me, hand, thing, destination):
        if thing in hand.touching and hand.cooldown == 0:
            return self.ids["grasp"]
        ox, oy = thing.body.position
        size = _size(thing)
        side = self._side(episode, thing, destination)
        stand = size + self.radius + self.reach + 2.0
        spot = (ox + side[0] * stand, oy + side[1] * stand)
        x, y = me.body.position
        if math.dist((x, y), spot) > ARRIVED and math.dist((x, y), (ox, oy)) > stand + 4.0:
            return self._walk(episode, me, thing, spot)
        return self._steer(me, (ox, oy))

    def _side(self, episode, thing, destination) -> tuple[float, float]:
        """The unit vector from the object to the side this agent takes."""
        ox, oy = thing.body.position
        back = math.atan2(oy - destination[1], ox - destination[0])
        sharing = [i for i in range(len(episode.bodies)) if self._shares(i)]
        slot = sharing.index(self.index) if self.index in sharing else 0
        angle = back + (slot - (len(sharing) - 1) / 2) * SIDE_SPREAD
        return math.cos(angle), math.sin(angle)

    def _shares(self, i: int) -> bool:
        team = self.env.spec.team_of(i)
        mine = (team.name if team else None) == self.team
        return mine and not self.env.episode.task.records[i].done

    # -- pushing --------------------------------------------------------------------------

    def _push(self, episode, me, thing, destination):
        ox, oy = thing.body.position
        ux, uy = destination[0] - ox, destination[1] - oy
        norm = math.hypot(ux, uy) or 1.0
        ux, uy = ux / norm, uy / norm
        behind = _size(thing) + self.radius + 4.0
        spot = (ox - ux * behind, oy - uy * behind)
        x, y = me.body.position
        to_thing = math.atan2(oy - y, ox - x)
        aligned = abs(wrap_angle(to_thing - math.atan2(uy, ux))) < math.radians(25)
        if not aligned or math.dist((x, y), (ox, oy)) > behind + 8.0:
            return self._walk(episode, me, thing, spot)
        return self._steer(me, (ox + ux * 15.0, oy + uy * 15.0))

    # -- moving ---------------------------------------------------------------------------

    def _walk(self, episode, me, thing, spot):
        """One step along the shortest path to ``spot``, going round the object."""
        grid = episode.grid_for(self.radius).copy()
        grid.block_shape(thing.shapes[0], extra=self.span + 4.0)  # keep the arms off it
        x, y = me.body.position
        here = grid.cell_of(x, y)
        grid.blocked[here] = False
        goal = grid.cell_of(*spot)
        grid.blocked[goal] = False
        field = grid.distances(mask_at(grid, [goal]))
        waypoint = descend(field, here, 3)
        target = grid.centre(*waypoint) if waypoint != here else spot
        return self._steer(me, target)

    def _steer(self, me, target, tolerance: float | None = None):
        x, y = me.body.position
        angle = wrap_angle(math.atan2(target[1] - y, target[0] - x) - me.body.angle)
        if abs(angle) > (tolerance if tolerance is not None else self.turn_step * 0.6):
            return self.ids["rotate_left" if angle > 0 else "rotate_right"]
        return self.ids["forward"]


def _carrying_arm(agent):
    """The arm it carries with: of those with a grasper, the one pointing most nearly
    ahead (without graspers, the first arm, to push with). Returns the arm, its hand's
    index among the graspers and the names of that hand's grasp and release actions."""
    graspers = [arm for arm in agent.arms if arm.grasper is not None]
    if not graspers:
        return (agent.arms[0] if agent.arms else None), None, None
    h = min(range(len(graspers)), key=lambda k: abs(graspers[k].mount))
    (control,) = [p for p in make_parts(agent) if isinstance(p, Grasper)][h].controls
    return graspers[h], h, (control.plus, control.minus)


def _objects(episode) -> list[Obstacle]:
    return [e for e in episode.world.entities if isinstance(e, Obstacle) and e.moving]


def _size(thing: Obstacle) -> float:
    shape = thing.shapes[0]
    if hasattr(shape, "radius") and not hasattr(shape, "get_vertices"):
        return shape.radius
    return max(v.length for v in shape.get_vertices())


def _door_centre(door) -> tuple[float, float]:
    verts = [door.body.local_to_world(v) for v in door.shapes[0].get_vertices()]
    return (sum(v.x for v in verts) / len(verts), sum(v.y for v in verts) / len(verts))
