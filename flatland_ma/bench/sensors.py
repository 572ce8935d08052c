"""What each kind of sensor, and the global state, costs per agent-step.

Each setup gives every agent of ``fruits_poisons_multi`` one set of sensors; the suite
then casts all their rays and reads every agent's observation, timed alone (no physics,
no task), after a reset and a few steps so that the world looks as it does in play.

Smell reads a scent field that is searched again only when items are taken, come back or
move (none do while the suite alone is timed); what one search of both channels costs is
timed on its own, and the cost per agent-step in play is the reading plus that times the
share of steps on which an item changes, over the number of agents.

Touch also costs inside the physics step, where the world logs the pushes it reads: a
row of its own times that.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import flatland_ma
from flatland_ma.sensors.smell import Smell

SCENARIO = "fruits_poisons_multi"
SMELL = {"type": "smell", "sources": ["fruits", "poisons"]}
SETUPS = (
    ("camera, 64 rays (the default)", [{"type": "camera"}]),
    ("lidar, 32 rays", [{"type": "lidar"}]),
    ("camera + lidar", [{"type": "camera"}, {"type": "lidar"}]),
    (
        "camera with one-hot semantic channels",
        [{"type": "camera", "channels": ["rgb", "depth", "semantic"], "semantic": "onehot"}],
    ),
    ("camera + proprioception", [{"type": "camera"}, {"type": "proprioception"}]),
    ("top-down, 32 x 32 rgb", [{"type": "topdown"}]),
    ("top-down, 32 x 32 rgb, masked", [{"type": "topdown", "masked": True}]),
    ("camera + touch, 8 sectors", [{"type": "camera"}, {"type": "touch"}]),
    ("smell, 2 channels (fruits, poisons)", [SMELL]),
    ("camera + smell", [{"type": "camera"}, SMELL]),
)


@dataclass
class SensorCost:
    label: str
    micros_per_agent_step: float


def sensor_costs(steps: int = 5_000) -> list[SensorCost]:
    """Microseconds per agent-step of each setup's sensing, and of ``state()``."""
    costs = []
    env = None
    for label, sensors in SETUPS:
        env = flatland_ma.parallel_env(SCENARIO, agent={"sensors": sensors})
        suite, n = _warm(env), env.num_agents
        start = time.perf_counter()
        for _ in range(steps):
            suite.observe()
            for i in range(n):
                suite.observation(i)
        costs.append(SensorCost(label, 1e6 * (time.perf_counter() - start) / (steps * n)))
    costs.append(touch_logging_cost(steps))
    assert env is not None
    costs.append(_smell_search(steps // 10))
    start = time.perf_counter()
    for _ in range(steps):
        env.state()
    per_agent = 1e6 * (time.perf_counter() - start) / (steps * env.num_agents)
    costs.append(SensorCost("global state (state(), per env step / agents)", per_agent))
    return costs


def _smell_search(searches: int) -> SensorCost:
    """Microseconds one search of the scent field (both channels) takes, once per world."""
    env = flatland_ma.parallel_env(SCENARIO, agent={"sensors": [SMELL]})
    smell = _warm(env).cameras[0]
    assert isinstance(smell, Smell) and smell.field is not None, "no smell sensor"
    field = smell.field
    start = time.perf_counter()
    for _ in range(searches):
        for c in range(len(field.members)):
            field.search(c)
    micros = 1e6 * (time.perf_counter() - start) / searches
    return SensorCost("smell: one search of its field, when items change", micros)


def touch_logging_cost(steps: int, block: int = 50) -> SensorCost:
    """What logging pushes for touch sensors adds to the physics step, per agent-step.

    Two copies of one world, with and without touch sensors, step alike (feeling changes
    nothing in the physics), every agent driving ahead so that most of them press on a
    wall, an obstacle or each other; blocks of steps alternate between the two so that
    both share the machine's load. The difference is the cost (near zero, it may come
    out slightly negative).
    """
    sensors = [{"type": "camera"}]
    worlds, n = [], 1
    for extra in ([], [{"type": "touch"}]):
        env = flatland_ma.parallel_env(SCENARIO, agent={"sensors": sensors + extra})
        env.reset(seed=0)
        for _ in range(20):
            env.step(dict.fromkeys(env.agents, env.action_index("forward")))
        worlds.append(env.running.world)
        n = env.num_agents
    spent = [0.0, 0.0]
    blocks = max(1, steps // block)
    for _ in range(blocks):
        for i, world in enumerate(worlds):
            start = time.perf_counter()
            for _ in range(block):
                world.step()
            spent[i] += time.perf_counter() - start
    per_agent = 1e6 * (spent[1] - spent[0]) / (blocks * block * n)
    return SensorCost("touch: logging pushes while all press", per_agent)


def _warm(env):
    env.reset(seed=0)
    for _ in range(20):
        env.step({a: env.action_space(a).sample() for a in env.agents})
    return env.running.sensors


def format_costs(costs: list[SensorCost]) -> str:
    lines = [f"{'sensing, ' + SCENARIO:48} {'us per agent-step':>18}", "-" * 67]
    lines += [f"{c.label:48} {c.micros_per_agent_step:>18.1f}" for c in costs]
    return "\n".join(lines)
