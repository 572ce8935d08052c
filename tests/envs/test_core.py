"""The core the envs stand on: a world loop's public stages give the parallel env's step,
and no module of the envs reads another's private members."""

import ast
from pathlib import Path

import numpy as np

import flatland_ma
from flatland_ma.envs.world_loop import WorldLoop

PACKAGE = Path(__file__).resolve().parents[2] / "flatland_ma"


def test_a_world_loops_stages_give_the_parallel_envs_step():
    env = flatland_ma.parallel_env("fruits_poisons_multi", max_cycles=40)
    loop = WorldLoop(env.spec, None)
    env.reset(seed=7)
    loop.start(7)
    spaces = [env.action_space(a) for a in env.possible_agents]
    for i, space in enumerate(spaces):
        space.seed(i)
    steps = 0
    while env.agents:
        actions = {a: spaces[i].sample() for i, a in enumerate(env.possible_agents)}
        observations, rewards, terminations, truncations, _ = env.step(actions)
        loop.act([loop.check_action(a, actions[a]) for a in loop.agents])
        rewards_now, terminated = loop.simulate()
        loop.running.sensors.observe()
        live, rewards_now, terminated, truncated = loop.conclude(rewards_now, terminated)
        names = [loop.possible_agents[i] for i in live]
        assert names == list(observations)
        for i, name in zip(live, names):
            assert np.array_equal(loop.observe(i), observations[name])
            assert rewards_now[i] == rewards[name]
            assert terminated[i] == terminations[name] and truncated == truncations[name]
        assert loop.agents == env.agents and loop.num_steps == env.num_steps
        steps += 1
    assert steps == 40 and loop.live == []


def test_the_envs_read_no_other_modules_private_members():
    files = sorted((PACKAGE / "envs").glob("*.py")) + [PACKAGE / "lifelong" / "batched.py"]
    found = []
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.Attribute) and node.attr.startswith("_")):
                continue
            if node.attr.startswith("__"):
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue
            found.append(f"{path.name}:{node.lineno}: {ast.unparse(node)}")
    assert found == []
