"""Plain bodies are driven through ``agents.motors`` by every env, the single env too:
the same numbers, to the bit, as their own attributes give (the physics bridge's
attribute tier drives every body through ``Actuator.apply``), whatever mix of actions
the agents take and however many of them still play."""

import numpy as np
import pytest

import flatland_ma
from flatland_ma.agents import motors
from flatland_ma.world import physics
from flatland_ma.world.tier import Tier

MIXED = {
    "n_agents": 3,
    "teams": [
        {"name": "a", "size": 2},
        {"name": "b", "size": 1, "agent": {"actions": "continuous"}},
    ],
    # Terminal items end one agent's episode at a time, so some steps drive only some.
    "items": [{"name": "goal", "color": "lime", "reward": 10, "terminal": True, "count": 12}],
}


def _trajectory(tier: Tier, monkeypatch) -> tuple[list, list[int], int]:
    """Every body's pose and velocities after each step of one seeded episode in ``tier``;
    how many agents acted at each step; how many of those steps went through ``Motors``."""
    monkeypatch.setattr(physics, "TIER", tier)
    driven = []
    drive, drive_all = motors.Motors.drive, motors.Motors.drive_all
    monkeypatch.setattr(
        motors.Motors, "drive", lambda self, *a: (driven.append(1), drive(self, *a))
    )
    monkeypatch.setattr(
        motors.Motors, "drive_all", lambda self, *a: (driven.append(1), drive_all(self, *a))
    )
    env = flatland_ma.parallel_env("fruits_poisons_multi", **MIXED)
    env.reset(seed=3)
    for agent in env.possible_agents:
        env.action_space(agent).seed(1)
    states, acting = [], []
    while env.agents and len(states) < 400:
        acting.append(len(env.agents))
        env.step({a: env.action_space(a).sample() for a in env.agents})
        states.append(
            [
                (*b.body.position, b.body.angle, *b.body.velocity, b.body.angular_velocity)
                for b in env.running.bodies
            ]
        )
    env.close()
    return states, acting, len(driven)


def test_the_single_env_drives_plain_bodies_of_any_actions_as_their_attributes_would(
    monkeypatch,
):
    assert physics.TIER is Tier.COMPILED
    compiled, acting, driven = _trajectory(Tier.COMPILED, monkeypatch)
    attributes, acting_too, undriven = _trajectory(Tier.ATTRIBUTES, monkeypatch)
    assert 1 in acting and 3 in acting  # steps of all three, and of one still playing
    assert driven == len(acting) and undriven == 0
    assert acting == acting_too
    np.testing.assert_array_equal(np.array(compiled), np.array(attributes))


@pytest.mark.parametrize(("scenario", "plain"), [("push_box", True), ("coop_carry", False)])
def test_only_plain_bodies_get_motors(scenario, plain):
    """coop_carry's agents have graspers: their bodies are driven through ``apply``."""
    env = flatland_ma.parallel_env(scenario)
    env.reset(seed=0)
    bodies = env.running.bodies
    assert all(not b.parts and not b.links for b in bodies) == plain
    assert (motors.motors_of(bodies) is not None) == plain
    env.close()
