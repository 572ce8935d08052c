"""What an episode of a scenario holds, counted from the file, and picked out of a built
episode in the same order: the things the global state describes (``sensors/world_state``).
"""

from __future__ import annotations

from flatland_ma.build.builder import Episode
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.world_state import StateCounts, WorldState
from flatland_ma.world.entities import Item, Obstacle


def state_counts(spec: ScenarioSpec) -> StateCounts:
    """Agents, items by group, movable objects and doors, as every episode builds them."""
    doors = len(spec.all_doors())
    for gen in spec.layout.generators:
        if gen.generator == "grid_rooms" and gen.doors != "none":
            doors += gen.rows * (gen.cols - 1) + gen.cols * (gen.rows - 1)
    return StateCounts(
        agents=spec.n_agents,
        items=tuple((item.name, item.n_items) for item in spec.items),
        objects=sum(1 for obstacle in spec.obstacles if obstacle.movable),
        doors=doors,
    )


def world_state(spec: ScenarioSpec) -> WorldState:
    agents = spec.agent_specs
    return WorldState(
        spec.arena.size,
        state_counts(spec),
        [a.max_speed for a in agents],
        [a.max_turn_rate for a in agents],
        spec.channel.tokens if spec.channel else 0,
        spec.channel.vocabulary if spec.channel else 2,
        spec.agent_names,
    )


def state_entities(episode: Episode) -> tuple[list, list, list, list]:
    """The agents' bases, items, movable objects and doors of an episode, in the order the
    state lists them (the order they were built in)."""
    world = episode.world
    items = world.of_type(Item)
    objects = [e for e in world.of_type(Obstacle) if e.moving]
    return list(world.agents), items, objects, list(episode.doors)
