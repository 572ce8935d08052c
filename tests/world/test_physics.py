"""Bodies against physical invariants: exact kinematics in free space, no tunnelling,
no overlap, pushing movable obstacles and not static ones."""

import math

import numpy as np
import pytest

import flatland_ma

EMPTY = {"obstacles": [], "items": []}


def place(env, index, x, y, angle):
    agent = env.episode.bodies[index]
    agent.body.position = (x, y)
    agent.body.angle = angle
    agent.body.velocity = (0.0, 0.0)
    agent.body.angular_velocity = 0.0
    env.episode.world.space.reindex_shapes_for_body(agent.body)


def test_forward_and_rotate_move_exactly_one_step_in_free_space():
    env = flatland_ma.parallel_env("fruits_poisons", **EMPTY)
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.3)
    body = env.episode.bodies[0].body
    spec = env.spec
    step = spec.agent.max_speed * spec.physics.dt
    turn = math.radians(spec.agent.max_turn_rate) * spec.physics.dt
    for action in [1, 1, 2, 0, 0, 2, 1, 0]:
        x, y, a = *body.position, body.angle
        env.step({"agent_0": action})
        if action == 0:
            assert body.position.x - x == pytest.approx(step * math.cos(a), abs=1e-9)
            assert body.position.y - y == pytest.approx(step * math.sin(a), abs=1e-9)
            assert body.angle == pytest.approx(a, abs=1e-12)
        else:
            assert body.angle - a == pytest.approx(turn if action == 1 else -turn, abs=1e-12)
            assert (body.position.x, body.position.y) == pytest.approx((x, y), abs=1e-9)


def test_continuous_actions_scale_the_velocities():
    env = flatland_ma.parallel_env("fruits_poisons", agent={"actions": "continuous"}, **EMPTY)
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    body = env.episode.bodies[0].body
    env.step({"agent_0": np.array([0.5, -0.25, 0.0], np.float32)})
    step = env.spec.agent.max_speed * env.spec.physics.dt
    assert body.position.x - 150.0 == pytest.approx(0.5 * step)
    assert body.position.y - 150.0 == pytest.approx(-0.25 * step)  # lateral: to the left is +


def _inside_arena(env, slack):
    w, h = env.spec.arena.size
    r = env.spec.agent.radius
    for b in env.episode.bodies:
        x, y = b.body.position
        assert r - slack <= x <= w - r + slack and r - slack <= y <= h - r + slack, (x, y)


@pytest.mark.parametrize("n_agents", [4, 8])
def test_agents_crowding_at_top_speed_stay_out_of_walls_and_each_other(n_agents):
    # Agents driving flat out, pressing each other into walls and corners: contacts may
    # sink a little (discrete time at top speed), never halfway into a wall.
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi", n_agents=n_agents, agent={"actions": "continuous"}
    )
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    r = env.spec.agent.radius
    half_wall = env.spec.arena.wall.thickness / 2
    for _ in range(2000):
        if not env.agents:
            env.reset()
        actions = {a: np.array([1.0, 0.0, rng.uniform(-0.3, 0.3)], np.float32) for a in env.agents}
        env.step(actions)
        _inside_arena(env, slack=half_wall)
        positions = np.array([b.body.position for b in env.episode.bodies])
        gaps = np.linalg.norm(positions[:, None] - positions[None], axis=2)
        assert (gaps + np.eye(n_agents) * 1e9).min() > 2 * r - half_wall


def substep_travel(env) -> float:
    spec = env.spec
    return spec.agent.max_speed * spec.physics.dt / spec.physics.substeps


@pytest.mark.parametrize("heading_deg", [0, 37, 90, 135, 180, 251, 270, 333])
def test_driving_straight_into_a_wall_at_top_speed_stops_at_it(heading_deg):
    # The impact may sink by at most one substep's travel; pushing on, the solver brings
    # the overlap back to pymunk's collision slop.
    env = flatland_ma.parallel_env("fruits_poisons", **EMPTY)
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, math.radians(heading_deg))
    for _ in range(100):
        env.step({"agent_0": 0})
        _inside_arena(env, slack=substep_travel(env))
    _inside_arena(env, slack=env.episode.world.space.collision_slop + 0.05)


def test_agents_do_not_pass_through_obstacles():
    env = flatland_ma.parallel_env("fruits_poisons_multi", items=[])
    env.reset(seed=2)
    world = env.episode.world
    obstacle_shapes = [
        s for e in world.entities if type(e).__name__ == "Obstacle" for s in e.shapes
    ]
    r = env.spec.agent.radius
    for t in range(1500):
        if not env.agents:
            env.reset()
            world = env.episode.world
            obstacle_shapes = [
                s for e in world.entities if type(e).__name__ == "Obstacle" for s in e.shapes
            ]
        env.step({a: 0 if (t // 40) % 4 else 1 for a in env.agents})
        for b in env.episode.bodies:
            for shape in obstacle_shapes:
                info = shape.point_query(b.body.position)
                assert info.distance > r - substep_travel(env)


def test_movable_obstacles_are_pushed_and_static_ones_are_not():
    box = {"shape": "box", "position": [150, 150], "size": [30, 30], "color": "green"}
    for movable in (True, False):
        env = flatland_ma.parallel_env(
            "fruits_poisons",
            items=[],
            obstacles=[{**box, "movable": movable, "mass": 5.0}],
        )
        env.reset(seed=0)
        place(env, 0, 100.0, 150.0, 0.0)
        obstacle = env.episode.world.entities[1].body
        for _ in range(30):
            env.step({"agent_0": 0})
        moved = obstacle.position.x - 150.0
        if movable:
            assert moved > 20.0
            # Floor friction: once the push stops, it comes to rest.
            for _ in range(30):
                env.step({"agent_0": 1})
            assert obstacle.velocity.length < 1e-6
        else:
            assert moved == 0.0
            assert env.episode.bodies[0].body.position.x < 150.0 - 15.0 - 10.0 + 0.5


def test_an_obstacle_too_heavy_for_the_motor_does_not_move():
    box = {"shape": "box", "position": [150, 150], "size": [30, 30], "movable": True}
    env = flatland_ma.parallel_env(
        "fruits_poisons",
        items=[],
        obstacles=[{**box, "mass": 1000.0, "floor_friction": 1.0}],
    )
    env.reset(seed=0)
    place(env, 0, 100.0, 150.0, 0.0)
    for _ in range(30):
        env.step({"agent_0": 0})
    assert env.episode.world.entities[1].body.position.x == pytest.approx(150.0, abs=0.5)
