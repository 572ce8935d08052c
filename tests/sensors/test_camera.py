"""First-person observations: walls at analytic distances, colour fading with distance,
other agents in their colours, never oneself."""

import math

import numpy as np
import pytest

import flatland_ma
from flatland_ma.build.bodies import make_sensors


def place(env, index, x, y, angle):
    body = env.episode.bodies[index].body
    body.position, body.angle = (x, y), angle
    env.episode.world.space.reindex_shapes_for_body(body)


def observe(env):
    env.episode.sensors.observe()
    return {a: env.episode.sensors.observation(i) for i, a in enumerate(env.possible_agents)}


def expected_wall_distance(x, y, heading, angles, width, height):
    out = []
    for a in heading + angles:
        c, s = math.cos(a), math.sin(a)
        candidates = []
        if c > 1e-12:
            candidates.append((width - x) / c)
        if c < -1e-12:
            candidates.append(-x / c)
        if s > 1e-12:
            candidates.append((height - y) / s)
        if s < -1e-12:
            candidates.append(-y / s)
        out.append(min(candidates))
    return np.array(out)


@pytest.mark.parametrize("x, y, heading", [(150, 150, 0.0), (60, 230, 2.0), (250, 40, -1.2)])
def test_an_empty_room_is_seen_at_the_analytic_distances(x, y, heading):
    env = flatland_ma.parallel_env(
        "fruits_poisons", obstacles=[], items=[], agent={"camera": {"range": 500}}
    )
    env.reset(seed=0)
    place(env, 0, x, y, heading)
    obs = observe(env)["agent_0"]
    camera = env.episode.sensors.cameras[0]
    expected = expected_wall_distance(x, y, heading, camera.angles, *env.spec.arena.size)
    np.testing.assert_allclose(obs[:, 3], expected / 500.0, rtol=1e-6)
    wall = np.array(env.spec.arena.wall.color)
    np.testing.assert_allclose(
        obs[:, :3], np.outer(1 - expected / 500.0, wall), rtol=1e-5, atol=1e-7
    )


def test_rays_are_spread_over_the_field_of_view_left_to_right():
    (camera,) = make_sensors(flatland_ma.load_scenario("fruits_poisons").agent)
    assert camera.n_rays == 64
    step = math.radians(120) / 64
    np.testing.assert_allclose(np.diff(camera.angles), -step)
    assert camera.angles[0] == pytest.approx(math.radians(60) - step / 2)
    assert camera.angles[-1] == pytest.approx(-camera.angles[0])


def test_agents_see_each_other_in_their_colours_and_never_themselves():
    env = flatland_ma.parallel_env("fruits_poisons_multi", obstacles=[], items=[], n_agents=2)
    env.reset(seed=0)
    place(env, 0, 100.0, 150.0, 0.0)
    place(env, 1, 160.0, 150.0, math.pi)
    obs = observe(env)
    sensors = env.episode.sensors
    bodies = env.episode.bodies
    for i, agent in enumerate(env.possible_agents):
        hits = sensors.hit_entity[sensors.slices[i]]
        assert bodies[i].index not in hits
        other = bodies[1 - i]
        seen = hits == other.index
        assert seen.sum() >= 3  # the other agent fills the middle of the view
        middle = env.spec.agent.camera.rays // 2
        assert seen[middle - 1] and seen[middle]
        d = obs[agent][seen, 3] * env.spec.agent.camera.range
        np.testing.assert_allclose(
            obs[agent][seen, :3],
            np.outer(1 - d / env.spec.agent.camera.range, other.color),
            rtol=1e-5,
        )
        assert obs[agent][middle, 3] * env.spec.agent.camera.range == pytest.approx(50.0, abs=0.05)


def test_observations_lie_in_their_space_and_are_fresh_copies():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    observations, _ = env.reset(seed=3)
    for _ in range(50):
        for agent, obs in observations.items():
            assert obs.dtype == np.float32
            assert env.observation_space(agent).contains(obs)
        observations, *_ = env.step({a: 0 for a in env.agents})
    before = env.episode.sensors.image.copy()
    observations["agent_0"][:] = 7.0
    np.testing.assert_array_equal(env.episode.sensors.image, before)


def test_falloff_none_keeps_full_colour():
    env = flatland_ma.parallel_env(
        "fruits_poisons", obstacles=[], items=[], agent={"camera": {"falloff": "none"}}
    )
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    obs = observe(env)["agent_0"]
    np.testing.assert_allclose(obs[:, :3], np.tile(env.spec.arena.wall.color, (64, 1)), rtol=1e-6)


MULTI_AGENT = [s for s in flatland_ma.list_scenarios() if flatland_ma.load_scenario(s).n_agents > 1]


@pytest.mark.parametrize("scenario", MULTI_AGENT)
def test_shipped_agents_wear_colours_nothing_else_in_their_world_has(scenario):
    # Otherwise another agent is, in a 1-D image, indistinguishable from an obstacle.
    env = flatland_ma.parallel_env(scenario)
    env.reset(seed=0)
    agents = {id(body) for body in env.episode.bodies}
    agents |= {id(part) for body in env.episode.bodies for part in body.links}
    world_colours = set()
    for entity in env.episode.world.entities:
        if id(entity) not in agents:
            colours = [entity.color] if entity.texture is None else entity.texture.colors
            world_colours |= {tuple(np.round(c, 4)) for c in colours}
    for i, body in enumerate(env.episode.bodies):
        assert tuple(np.round(body.color, 4)) not in world_colours, (scenario, i, body.color)


@pytest.mark.parametrize("decay", [None, 40.0])
def test_exponential_falloff_fades_colour_by_exp_of_distance_over_decay(decay):
    """Agent at the room's centre heading east: the two rays, 1/4 degree either side of
    the heading, meet the wall's face (x = 300) at 150 / cos(1/4 degree), and their colour
    is the wall's times exp(-d / decay), decay a third of the range when not given."""
    camera = {"falloff": "exponential", "rays": 2, "fov": 1.0}
    if decay is not None:
        camera["decay"] = decay
    env = flatland_ma.parallel_env(
        "fruits_poisons", obstacles=[], items=[], agent={"camera": camera}
    )
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    obs = observe(env)["agent_0"]
    distance = env.episode.sensors.distance[:2]
    scale = decay if decay is not None else env.spec.agent.camera.range / 3.0
    expected = np.outer(np.exp(-distance / scale), env.spec.arena.wall.color)
    np.testing.assert_allclose(obs[:, :3], expected, rtol=1e-5)
    np.testing.assert_allclose(distance, 150.0 / math.cos(math.radians(0.25)), rtol=1e-9)
    np.testing.assert_allclose(obs[:, 3], distance / env.spec.agent.camera.range, rtol=1e-5)
