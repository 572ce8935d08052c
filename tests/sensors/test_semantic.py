"""The camera's channels: the kind of thing each ray hits, against a scene set by hand."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.sensors.semantic import SEMANTIC_KINDS

DOT = {"name": "dot", "color": "red", "positions": [[200, 150]]}
KIND = {name: k for k, name in enumerate(SEMANTIC_KINDS)}


def _see(camera, x=150.0, y=150.0, heading=0.0, **overrides):
    sensors = [{"type": "camera", "rays": 5, "fov": 40, **camera}]
    overrides = {"items": [DOT], **overrides}
    env = flatland_ma.parallel_env("fruits_poisons", agent={"sensors": sensors}, **overrides)
    env.reset(seed=0)
    episode = env.episode
    episode.world.place(episode.bodies[0], x, y, heading)
    episode.sensors.observe()
    observation = episode.sensors.observation(0)
    assert env.observation_space("agent_0").contains(observation)
    return observation


def test_the_middle_ray_sees_an_item_ahead_and_the_others_the_wall_behind_it():
    seen = _see({"channels": ["semantic", "depth"], "range": 400})
    assert seen[:, 0].tolist() == [KIND["wall"]] * 2 + [KIND["item"]] + [KIND["wall"]] * 2
    assert seen[2, 1] == pytest.approx((200 - 6 - 150) / 400, abs=1e-6)  # the dot's near side


def test_nothing_within_range_is_kind_zero_and_one_hot_has_one_one_per_ray():
    seen = _see({"channels": ["semantic"], "semantic": "onehot", "range": 30})
    assert seen.shape == (5, len(SEMANTIC_KINDS))
    assert (seen.sum(axis=1) == 1).all() and (seen[:, KIND["nothing"]] == 1).all()


def test_other_agents_doors_and_obstacles_have_their_kinds():
    door = {"start": [250, 100], "end": [250, 200]}
    seen = _see({"channels": ["semantic"], "range": 400}, doors=[door], items=[])
    assert (seen[:, 0] == KIND["door"]).all()
    seen = _see({"channels": ["semantic"], "range": 400}, x=150.0, y=220.0, heading=np.pi)
    assert seen[2, 0] == KIND["obstacle"]  # the green circle at (80, 220)
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi", agent={"sensors": [{"type": "camera", "channels": ["semantic"]}]}
    )
    env.reset(seed=0)
    episode = env.episode
    episode.world.place(episode.bodies[0], 150.0, 150.0, 0.0)
    episode.world.place(episode.bodies[1], 190.0, 150.0, 0.0)
    episode.sensors.observe()
    assert episode.sensors.observation(0)[32, 0] == KIND["agent"]


def test_default_channels_are_unchanged_and_channels_combine_in_order():
    plain = _see({})
    both = _see({"channels": ["rgb", "depth", "semantic"]})
    assert plain.shape == (5, 4) and np.array_equal(both[:, :4], plain)
    flipped = _see({"channels": ["depth", "rgb"]})
    assert np.array_equal(flipped[:, 0], plain[:, 3]) and np.array_equal(
        flipped[:, 1:], plain[:, :3]
    )
    sensors = [{"type": "camera", "channels": ["rgb", "semantic"], "semantic": "onehot"}]
    parallel_api_test(flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors}))


def test_a_channel_given_twice_is_located():
    with pytest.raises(ScenarioError) as info:
        flatland_ma.load_scenario("fruits_poisons", agent={"camera": {"channels": ["rgb", "rgb"]}})
    assert str(info.value.problems[0]).startswith("<overrides>: agent.camera:")
