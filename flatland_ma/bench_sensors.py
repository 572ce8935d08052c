"""What each kind of sensor, and the global state, costs per agent-step.

Each setup gives every agent of ``fruits_poisons_multi`` one set of sensors; the suite
then casts all their rays and reads every agent's observation, timed alone (no physics,
no task), after a reset and a few steps so that the world looks as it does in play.
Touch also costs inside the physics step, where the world logs the pushes it reads: a
row of its own times that.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import flatland_ma

SCENARIO = "fruits_poisons_multi"
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
    start = time.perf_counter()
    for _ in range(steps):
        env.state()
    per_agent = 1e6 * (time.perf_counter() - start) / (steps * env.num_agents)
    costs.append(SensorCost("global state (state(), per env step / agents)", per_agent))
    return costs


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
