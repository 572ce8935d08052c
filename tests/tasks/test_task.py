"""Foraging: touching an item rewards the agent, counts in its infos, and the item
reappears at a free place (or vanishes, if it never respawns)."""

import math

import numpy as np
import pytest

import flatland_ma
from flatland_ma.world.entities import Item


def items(env):
    return [e for e in env.episode.world.entities if isinstance(e, Item)]


def put_item_ahead(env, agent_index, group, distance):
    """Move the first visible item of ``group`` straight ahead of the agent."""
    body = env.episode.bodies[agent_index].body
    item = next(i for i in items(env) if i.group.index == group and i.visible)
    x = body.position.x + distance * math.cos(body.angle)
    y = body.position.y + distance * math.sin(body.angle)
    env.episode.world.move_static(item, x, y)
    env.episode.sensors.geometry.update_entity(item)
    return item


def face_open_space(env, index=0):
    body = env.episode.bodies[index].body
    body.position = (150.0, 150.0)
    body.angle = 0.0
    env.episode.world.space.reindex_shapes_for_body(body)


@pytest.fixture
def env():
    env = flatland_ma.parallel_env("fruits_poisons", obstacles=[])
    env.reset(seed=0)
    # Clear the way: park every item in a corner row, far from the agent.
    for k, item in enumerate(items(env)):
        env.episode.world.move_static(item, 15.0 + 13.0 * k, 285.0)
        env.episode.sensors.geometry.update_entity(item)
    face_open_space(env)
    return env


@pytest.mark.parametrize("group, reward, counter", [(0, 10.0, "fruits"), (1, -10.0, "poisons")])
def test_touching_an_item_gives_its_reward_and_counts(env, group, reward, counter):
    item = put_item_ahead(env, 0, group, 30.0)
    total = 0.0
    for _ in range(6):
        _, rewards, _, _, infos = env.step({"agent_0": 0})
        total += rewards["agent_0"]
    assert total == reward
    assert infos["agent_0"][counter] == 1
    assert infos["agent_0"]["score"] == reward
    # It reappeared elsewhere, at a free place, and the room holds as many as before.
    assert item.visible
    assert math.dist(item.body.position, env.episode.bodies[0].body.position) > 20.0
    assert sum(i.group.index == group and i.visible for i in items(env)) == 10


def test_rewards_are_floats_and_counters_start_at_zero(env):
    _, infos = env.reset(seed=1)
    assert infos["agent_0"] == {"score": 0.0, "fruits": 0, "poisons": 0}
    _, rewards, terminations, truncations, infos = env.step({"agent_0": 1})
    assert type(rewards["agent_0"]) is float
    assert type(terminations["agent_0"]) is bool and type(truncations["agent_0"]) is bool


def test_items_that_never_respawn_vanish_from_world_and_view():
    env = flatland_ma.parallel_env(
        "fruits_poisons",
        obstacles=[],
        items=[
            {"name": "fruits", "color": "orange", "reward": 1.0, "count": 1, "respawn": "never"}
        ],
    )
    env.reset(seed=0)
    face_open_space(env)
    item = put_item_ahead(env, 0, 0, 40.0)
    env.step({"agent_0": 1})
    env.step({"agent_0": 2})  # look at it again: now it is seen
    assert (env.episode.sensors.hit_entity == item.index).any()
    rewards = [env.step({"agent_0": 0})[1]["agent_0"] for _ in range(8)]
    assert sum(rewards) == 1.0
    assert not item.visible
    assert not (env.episode.sensors.hit_entity == item.index).any()
    assert item.shapes[0].space is None


def test_two_agents_touching_one_item_in_one_step_share_nothing():
    env = flatland_ma.parallel_env("fruits_poisons_multi", obstacles=[], n_agents=2)
    env.reset(seed=0)
    for k, item in enumerate(items(env)):
        env.episode.world.move_static(item, 15.0 + 13.0 * k, 285.0)
    bodies = env.episode.bodies
    for b, x, a in ((bodies[0], 120.0, 0.0), (bodies[1], 180.0, math.pi)):
        b.body.position, b.body.angle = (x, 150.0), a
        env.episode.world.space.reindex_shapes_for_body(b.body)
    fruit = next(i for i in items(env) if i.group.index == 0)
    env.episode.world.move_static(fruit, 150.0, 150.0)
    total = {"agent_0": 0.0, "agent_1": 0.0}
    for _ in range(4):
        _, rewards, *_ = env.step({"agent_0": 0, "agent_1": 0})
        for a, r in rewards.items():
            total[a] += r
    assert sorted(total.values()) == [0.0, 10.0]


def test_truncation_at_the_episode_length():
    env = flatland_ma.parallel_env("fruits_poisons_multi", episode={"max_steps": 7})
    env.reset(seed=0)
    for t in range(7):
        assert len(env.agents) == 4
        _, _, terminations, truncations, _ = env.step({a: 0 for a in env.agents})
        assert not any(terminations.values())
        assert all(truncations.values()) == (t == 6)
    assert env.agents == []


def test_respawns_come_from_the_env_generator_only():
    def run():
        env = flatland_ma.parallel_env("fruits_poisons")
        env.reset(seed=8)
        env.action_space("agent_0").seed(8)
        positions = []
        for _ in range(500):
            env.step({"agent_0": env.action_space("agent_0").sample()})
        for item in items(env):
            positions.append(tuple(item.body.position))
        return positions

    assert run() == run()
    np.random.seed(123)  # noqa: NPY002 - the global generator plays no part
    assert run() == run()
