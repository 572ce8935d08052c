"""Sensor noise: off by default, drawn from the env's seeded generator, and of the kind and
amount the file asks for (measured over many readings)."""

import numpy as np
import pytest

import flatland_ma
from flatland_ma.scenario.errors import ScenarioError

EMPTY = {"obstacles": [], "items": []}


def _env(*sensors):
    return flatland_ma.parallel_env("fruits_poisons", **EMPTY, agent={"sensors": list(sensors)})


def _readings(env, x=150.0, y=150.0, heading=0.0):
    """The observation at a fixed pose, and the same sensors' exact readings."""
    episode = env.episode
    episode.world.place(episode.bodies[0], x, y, heading)
    episode.sensors.observe()
    noisy = episode.sensors.observation(0)
    exact = {s.name: s.read(episode.sensors, k) for k, s in enumerate(episode.sensors.cameras)}
    return noisy, exact


def test_noise_is_off_unless_the_file_asks_for_it():
    for name in flatland_ma.list_scenarios():
        env = flatland_ma.parallel_env(name)
        for agent, own in zip(env.spec.agent_specs, env.sensors):
            for spec, sensor in zip(agent.sensor_specs, own):
                assert (sensor.noise is None) == (spec.noise is None), (name, sensor.name)


def test_a_sensor_without_noise_reads_exactly_and_draws_nothing():
    env = _env({"type": "lidar", "rays": 64}, {"type": "camera", "name": "eye"})
    env.reset(seed=3)
    before = env.np_random.bit_generator.state
    noisy, exact = _readings(env)
    assert env.np_random.bit_generator.state == before
    for name in exact:
        np.testing.assert_array_equal(noisy[name], exact[name])


def test_gaussian_noise_has_the_asked_spread_of_the_range():
    lidar = {"type": "lidar", "rays": 2048, "range": 400.0, "noise": {"gaussian": 0.02}}
    env = _env(lidar, {"type": "proprioception"})
    env.reset(seed=0)
    noisy, exact = _readings(env)
    error = noisy["lidar"] - exact["lidar"]  # distances 150..212 of 400: far from the bounds
    assert abs(error.mean()) < 0.002
    assert error.std() == pytest.approx(0.02, rel=0.1)
    assert env.observation_space("agent_0")["lidar"].contains(noisy["lidar"])


def test_salt_and_pepper_sets_whole_rays_to_their_bounds():
    camera = {"type": "camera", "rays": 2000, "fov": 90.0, "noise": {"salt_pepper": 0.2}}
    env = _env(camera, {"type": "lidar"})
    env.reset(seed=1)
    noisy, exact = _readings(env)
    rays = noisy["camera"]
    high = env.observation_space("agent_0")["camera"].high
    salt = (rays == high).all(axis=1)
    pepper = (rays == 0).all(axis=1)
    changed = (rays != exact["camera"]).any(axis=1)
    assert (changed <= salt | pepper).all()  # a changed ray is all-high or all-low
    assert (salt | pepper).mean() == pytest.approx(0.2, abs=0.03)
    assert salt.mean() == pytest.approx(0.1, abs=0.025)


def test_dropout_zeroes_readings_at_the_asked_rate():
    env = _env({"type": "lidar", "rays": 4000, "noise": {"dropout": 0.3}}, {"type": "camera"})
    env.reset(seed=2)
    noisy, exact = _readings(env)
    lost = noisy["lidar"] == 0
    assert not (exact["lidar"] == 0).any()
    assert lost.mean() == pytest.approx(0.3, abs=0.03)
    np.testing.assert_array_equal(noisy["lidar"][~lost], exact["lidar"][~lost])


def test_noise_is_reproducible_from_the_seed_and_differs_between_seeds():
    noise = {"gaussian": 0.05, "salt_pepper": 0.05, "dropout": 0.05}
    sensors = ({"type": "lidar", "noise": noise}, {"type": "camera", "noise": noise})

    def run(seed):
        env = _env(*sensors)
        out = [env.reset(seed=seed)[0]["agent_0"]]
        for t in range(20):
            out.append(env.step({"agent_0": t % 3})[0]["agent_0"])
        return out

    first, again, other = run(7), run(7), run(8)
    for a, b in zip(first, again):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    assert any(not np.array_equal(a["lidar"], b["lidar"]) for a, b in zip(first, other))


@pytest.mark.parametrize(
    "noise", [{"gaussian": -0.1}, {"dropout": 1.5}, {"salt_pepper": "often"}, {"blur": 0.1}]
)
def test_bad_noise_is_a_located_error(noise):
    with pytest.raises(ScenarioError, match="noise"):
        _env({"type": "lidar", "noise": noise}, {"type": "camera"})
