"""The left-hand rule from the agent's own camera: in a perfect maze it passes every
corridor, so it finds the goal wherever the maze puts it."""

import numpy as np
import pytest

import flatland_ma
from flatland_ma.policies import WallFollower, evaluate, make_policy


def small_maze(**overrides):
    """maze_goal's mazes on 4 x 4 cells (its 50-unit corridors): the whole left-hand walk
    (about 1,500 units) fits in an episode of 1,000 steps many times."""
    return flatland_ma.parallel_env("maze_goal", arena={"size": [200, 200]}, **overrides)


def test_wall_follower_finds_the_goal_in_every_small_maze():
    env = small_maze()
    scores = evaluate(env, lambda agent: make_policy("wall_follower", env, agent), episodes=8)
    assert scores.returns == [10.0] * 8, scores.returns


def test_wall_follower_keeps_the_wall_on_its_left():
    # In the open middle of a corridor it walks on; a wall close ahead turns it right,
    # one close on its left turns it right too, and the left falling away turns it left.
    env = small_maze()
    follower = WallFollower(env.spec)
    rays = len(follower.angles)
    depth = np.full(rays, 40.0 / follower.range)
    depth[follower.edge] = 30.0 / follower.range

    def decide(d, goal=None):
        image = np.zeros((rays, 4))
        image[:, :3] = 0.5 * (1.0 - d[:, None])  # a grey wall, its falloff applied
        if goal is not None:  # the goal's colour on these rays
            image[goal, :3] = np.array(env.spec.items[0].color) * (1.0 - d[goal, None])
        image[:, 3] = d
        return follower._decide(image)

    assert decide(depth) == (1.0, 0.0)
    ahead = depth.copy()
    ahead[follower.front] = 10.0 / follower.range
    assert decide(ahead) == (0.0, -1.0)
    hugging = depth.copy()
    hugging[follower.inner] = 10.0 / follower.range
    assert decide(hugging) == (0.0, -1.0)
    opening = depth.copy()
    opening[follower.edge | follower.inner] = 100.0 / follower.range
    assert decide(opening) == (0.0, 1.0)
    # The goal in view comes first: turned to on the right, walked to once ahead.
    right = follower.angles < -0.5
    assert decide(opening, goal=right) == (0.0, -1.0)
    assert decide(ahead, goal=follower.front) == (1.0, 0.0)


def test_wall_follower_needs_a_wide_camera():
    env = flatland_ma.parallel_env("maze_goal", agent={"camera": {"fov": 60}})
    with pytest.raises(ValueError, match="50 degrees"):
        WallFollower(env.spec)
