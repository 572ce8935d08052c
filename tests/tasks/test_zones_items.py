"""Zones act on entry; items may be keys, goals, come back late or at fixed places; the
episode may end for everyone."""

import numpy as np
import pytest

import flatland_ma
from tests.world_helpers import items, place, walk

OPEN = dict(obstacles=[])


def test_zone_rewards_on_each_entry_or_once():
    for once, expected in ((False, 2.0), (True, 1.0)):
        zone = {"rect": [140, 100, 160, 200], "reward": 1.0, "once": once}
        env = flatland_ma.parallel_env("fruits_poisons", items=[], zones=[zone], **OPEN)
        env.reset(seed=0)
        place(env, 0, 100.0, 150.0, 0.0)
        total, _ = walk(env, 14)  # east through the zone
        place(env, 0, 200.0, 150.0, np.pi)
        more, _ = walk(env, 14)  # and back west through it
        assert total + more == expected


def test_terminal_zone_ends_that_agent_only_and_retires_its_body():
    zone = {"rect": [0, 0, 40, 300], "terminal": True, "reward": 5.0}
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi", items=[], zones=[zone], n_agents=2, **OPEN
    )
    env.reset(seed=0)
    place(env, 0, 60.0, 150.0, np.pi)
    place(env, 1, 200.0, 150.0, 0.0)
    for _ in range(10):
        _, rewards, terminations, _, _ = env.step(
            {a: (0 if a == "agent_0" else 1) for a in env.agents}
        )
        if terminations.get("agent_0"):
            break
    assert terminations["agent_0"] and rewards["agent_0"] == 5.0 and not terminations["agent_1"]
    assert env.agents == ["agent_1"]
    body = env.episode.bodies[0]
    assert body.body.space is None and not body.visible
    env.episode.sensors.observe()
    assert body.index not in env.episode.sensors.hit_entity  # nobody sees it any more
    env.step({"agent_1": 0})  # the other agent goes on


def test_shared_end_ends_everyone():
    zone = {"rect": [0, 0, 40, 300], "terminal": True}
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi",
        items=[],
        zones=[zone],
        n_agents=2,
        episode={"shared_end": True},
        **OPEN,
    )
    env.reset(seed=0)
    place(env, 0, 60.0, 150.0, np.pi)
    place(env, 1, 200.0, 150.0, 0.0)
    for _ in range(10):
        _, _, terminations, _, _ = env.step({a: 0 if a == "agent_0" else 1 for a in env.agents})
        if env.agents == []:
            break
    assert terminations == {"agent_0": True, "agent_1": True}


def test_teleport_zone_moves_the_agent_inside_its_spawn_area():
    zone = {"rect": [140, 100, 160, 200], "reward": 10.0, "teleport": True}
    env = flatland_ma.parallel_env(
        "fruits_poisons",
        items=[],
        zones=[zone],
        agent={"spawn": {"area": [200, 200, 290, 290]}},
        **OPEN,
    )
    env.reset(seed=0)
    place(env, 0, 120.0, 150.0, 0.0)
    total, _ = walk(env, 5)
    x, y = env.episode.bodies[0].body.position
    assert total == 10.0 and 200 <= x <= 290 and 200 <= y <= 290


def test_random_zones_stay_put_for_the_episode_and_move_between_episodes():
    zone = {"size": [30, 30], "area": [0, 0, 300, 150], "reward": 1.0}
    env = flatland_ma.parallel_env("fruits_poisons", items=[], zones=[zone], **OPEN)
    env.reset(seed=0)
    first = [z.rect for z in env.episode.world.zones]
    walk(env, 30)
    np.testing.assert_array_equal([z.rect for z in env.episode.world.zones], first)
    x0, y0, x1, y1 = first[0]
    assert (x1 - x0, y1 - y0) == (30, 30) and y1 <= 150
    env.reset(seed=1)
    assert not np.array_equal([z.rect for z in env.episode.world.zones], first)


def test_delayed_respawn_and_fixed_positions():
    fruit = {
        "name": "fruits",
        "color": "orange",
        "reward": 1.0,
        "respawn": 20,
        "positions": [[160, 150]],
    }
    env = flatland_ma.parallel_env("fruits_poisons", items=[fruit], **OPEN)
    env.reset(seed=0)
    place(env, 0, 120.0, 150.0, 0.0)
    (item,) = items(env)
    total, _ = walk(env, 4)
    assert total == 1.0 and not item.visible
    place(env, 0, 60.0, 60.0, 0.0)
    walk(env, 15, action=1)
    assert not item.visible
    walk(env, 10, action=1)
    assert item.visible and tuple(item.body.position) == (160.0, 150.0)


def test_goal_items_end_the_episode_and_end_when_eaten():
    goal = {
        "name": "goal",
        "color": "lime",
        "reward": 10.0,
        "terminal": True,
        "positions": [[160, 150]],
    }
    env = flatland_ma.parallel_env("fruits_poisons", items=[goal], **OPEN)
    env.reset(seed=0)
    place(env, 0, 120.0, 150.0, 0.0)
    total, _ = walk(env, 6)
    assert total == 10.0 and env.agents == []

    food = {
        "name": "food",
        "color": "orange",
        "reward": 1.0,
        "respawn": "never",
        "positions": [[160, 150], [200, 150]],
    }
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi", n_agents=2, items=[food], episode={"end_when_eaten": "food"}, **OPEN
    )
    env.reset(seed=0)
    place(env, 0, 120.0, 150.0, 0.0)
    place(env, 1, 100.0, 250.0, 0.0)
    for _ in range(20):
        env.step({a: 0 if a == "agent_0" else 1 for a in env.agents})
        if not env.agents:
            break
    assert env.agents == [] and env.num_steps < 20


def test_a_shared_item_rewards_every_agent_still_playing():
    """agent_0 takes a shared +3 item, then a shared goal (+10) that ends its episode;
    agent_2 was out of the episode before either (a terminal zone): only the agents
    still playing are paid, the taker included."""
    shared = {"color": "orange", "reward": 3.0, "shared": True, "respawn": "never"}
    goal = {"color": "lime", "reward": 10.0, "shared": True, "terminal": True}
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi",
        n_agents=3,
        items=[
            {"name": "fruit", "positions": [[160, 150]], **shared},
            {"name": "goal", "positions": [[200, 150]], **goal},
        ],
        zones=[{"rect": [0, 0, 40, 300], "terminal": True}],
        **OPEN,
    )
    env.reset(seed=0)
    place(env, 0, 120.0, 150.0, 0.0)
    place(env, 1, 100.0, 250.0, 0.0)
    place(env, 2, 46.0, 50.0, np.pi)  # a step west of the terminal zone
    returns = dict.fromkeys(env.possible_agents, 0.0)
    for _ in range(20):
        _, rewards, _, _, infos = env.step({a: 1 if a == "agent_1" else 0 for a in env.agents})
        for agent, reward in rewards.items():
            returns[agent] += reward
        if "agent_0" not in env.agents:
            break
    assert "agent_2" not in env.agents and "agent_1" in env.agents
    assert returns == {"agent_0": 13.0, "agent_1": 13.0, "agent_2": 0.0}
    assert infos["agent_0"]["fruit"] == 1 and infos["agent_1"]["fruit"] == 0


def test_items_spawn_only_in_their_area():
    fruit = {
        "name": "fruits",
        "color": "orange",
        "reward": 1.0,
        "count": 15,
        "spawn": [200, 200, 290, 290],
    }
    env = flatland_ma.parallel_env("fruits_poisons", items=[fruit], **OPEN)
    for seed in range(3):
        env.reset(seed=seed)
        for item in items(env):
            x, y = item.body.position
            assert 200 <= x <= 290 and 200 <= y <= 290


@pytest.mark.parametrize("scenario", ["corridor_rooms", "key_door", "maze_goal"])
def test_items_and_agents_start_where_agents_can_reach(scenario):
    env = flatland_ma.parallel_env(scenario)
    for seed in range(5):
        env.reset(seed=seed)
        grid = env.episode.grid
        start = np.zeros_like(grid.blocked)
        start[grid.cell_of(*env.episode.bodies[0].body.position)] = True
        assert not grid.blocked[start].any()
        reach = grid.reachable(start)
        for item in items(env):
            assert reach[grid.cell_of(*item.body.position)]
