"""Setting up situations in a running env: placing agents, finding entities."""

from __future__ import annotations

import math

from flatland_ma.world.entities import Door, Item


def place(env, index, x, y, angle=0.0):
    """Put agent ``index`` (with its parts) at (x, y) facing ``angle``, at rest."""
    env.episode.bodies[index].teleport(x, y, angle)


def items(env, group=None):
    found = [e for e in env.episode.world.entities if isinstance(e, Item)]
    return [i for i in found if group is None or i.group.name == group]


def doors(env):
    return [e for e in env.episode.world.entities if isinstance(e, Door)]


def move_item(env, item, x, y):
    env.episode.world.move_static(item, x, y)
    env.episode.sensors.geometry.update_entity(item)


def walk(env, steps, action=0, agent="agent_0"):
    """Step with one action for one agent (others rotate in place); sum its rewards."""
    total, infos = 0.0, None
    for _ in range(steps):
        if agent not in env.agents:
            break
        actions = {a: (action if a == agent else 1) for a in env.agents}
        _, rewards, _, _, infos = env.step(actions)
        total += rewards.get(agent, 0.0)
    return total, infos


def heading_to(env, index, x, y):
    body = env.episode.bodies[index].body
    return math.atan2(y - body.position.y, x - body.position.x)
