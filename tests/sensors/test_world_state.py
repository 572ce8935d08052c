"""The global state (``env.state()``) against what was put in the world by hand: poses,
velocities, items taken, objects pushed, doors opened and agents gone."""

import math
import pickle

import numpy as np
import pytest

import flatland_ma
from flatland_ma.world.entities import Item


def _entry(env, label):
    return float(env.state()[env.state_labels.index(label)])


def test_an_agent_put_at_a_known_pose_and_velocity_reads_back():
    env = flatland_ma.parallel_env("fruits_poisons")
    env.reset(seed=0)
    body = env.episode.bodies[0].body
    body.position, body.angle = (75.0, 210.0), math.radians(120)
    body.velocity, body.angular_velocity = (110.0, -55.0), math.radians(-150)
    w, h = env.spec.arena.size
    speed, turn = env.spec.agent.max_speed, env.spec.agent.max_turn_rate
    expected = {
        "agent_0.x": 75 / w,
        "agent_0.y": 210 / h,
        "agent_0.cos": math.cos(math.radians(120)),
        "agent_0.sin": math.sin(math.radians(120)),
        "agent_0.vx": 110 / speed,
        "agent_0.vy": -55 / speed,
        "agent_0.turn": -150 / turn,
        "agent_0.alive": 1.0,
    }
    for label, value in expected.items():
        assert _entry(env, label) == pytest.approx(value, abs=1e-6), label
    body.velocity = (10 * speed, 0.0)  # pushed past its top speed: clipped into the space
    assert _entry(env, "agent_0.vx") == 1.0 and env.state_space.contains(env.state())


def test_items_read_their_place_and_whether_they_lie_in_the_arena():
    env = flatland_ma.parallel_env("fruits_poisons")
    env.reset(seed=1)
    world = env.episode.world
    items = world.of_type(Item)
    assert [i.group.name for i in items] == ["fruits"] * 10 + ["poisons"] * 10
    poison = items[13]  # the fourth poison
    x, y = poison.body.position
    assert _entry(env, "poisons[3].x") == pytest.approx(x / 300, abs=1e-6)
    assert _entry(env, "poisons[3].y") == pytest.approx(y / 300, abs=1e-6)
    assert _entry(env, "poisons[3].present") == 1.0
    world.withdraw(poison)
    assert _entry(env, "poisons[3].present") == 0.0 and _entry(env, "poisons[2].present") == 1.0


def test_a_pushed_box_and_a_swung_door_read_their_turn():
    env = flatland_ma.parallel_env("push_box")
    env.reset(seed=0)
    (box,) = env._state_parts[2]
    box.body.position, box.body.angle = (123.0, 45.0), 0.5
    w, h = env.spec.arena.size
    assert _entry(env, "object[0].x") == pytest.approx(123 / w, abs=1e-6)
    assert _entry(env, "object[0].y") == pytest.approx(45 / h, abs=1e-6)
    assert _entry(env, "object[0].sin") == pytest.approx(math.sin(0.5), abs=1e-6)

    env = flatland_ma.parallel_env("hinged_doors")
    env.reset(seed=0)
    door = env.episode.doors[2]
    door.body.angle = door.closed_angle + math.radians(70)
    assert _entry(env, "door[2].closed") == 1.0
    assert _entry(env, "door[2].sin") == pytest.approx(math.sin(math.radians(70)), abs=1e-6)
    assert _entry(env, "door[1].cos") == pytest.approx(1.0, abs=1e-3)  # still shut


def test_a_sliding_door_reads_open_once_opened():
    env = flatland_ma.parallel_env("key_door")
    env.reset(seed=0)
    (door,) = env.episode.doors
    assert _entry(env, "door[0].closed") == 1.0
    door.is_open = True
    assert _entry(env, "door[0].closed") == 0.0


def test_an_agent_whose_episode_ended_reads_gone_and_the_state_stays_in_its_space():
    goal = {"name": "goal", "color": "gold", "terminal": True, "positions": [[150, 200]]}
    env = flatland_ma.parallel_env("fruits_poisons", n_agents=2, items=[goal])
    env.reset(seed=0)
    world, (walker, turner) = env.episode.world, env.episode.bodies
    world.place(walker, 150.0, 160.0, math.pi / 2)  # facing the goal, 40 below it
    world.place(turner, 150.0, 40.0, 0.0)
    forward = env.action_index("forward")
    alive = []
    while "agent_0" in env.agents:  # agent_0 walks onto the goal; agent_1 turns in place
        assert env.state_space.contains(env.state())
        alive.append((_entry(env, "agent_0.alive"), _entry(env, "agent_1.alive")))
        env.step({"agent_0": forward, "agent_1": env.action_index("rotate_left")})
    assert set(alive) == {(1.0, 1.0)} and len(alive) < 100
    assert _entry(env, "agent_0.alive") == 0.0 and _entry(env, "agent_1.alive") == 1.0
    assert env.state_space.contains(env.state())


def test_the_state_is_reproducible_and_survives_pickling():
    def run(env, steps=40):
        env.reset(seed=7)
        rng = np.random.default_rng(3)
        for _ in range(steps):
            env.step({a: int(rng.integers(3)) for a in env.agents})
        return env

    a = run(flatland_ma.parallel_env("fruits_poisons_multi"))
    b = run(flatland_ma.parallel_env("fruits_poisons_multi"))
    assert np.array_equal(a.state(), b.state())
    c = pickle.loads(pickle.dumps(a))
    assert np.array_equal(c.state(), a.state())


def test_every_entry_is_named_and_the_space_matches():
    env = flatland_ma.parallel_env("forage_rooms_multi")
    labels = env.state_labels
    assert len(labels) == len(set(labels)) == env.state_space.shape[0]
    assert labels[:8] == tuple(
        f"agent_0.{f}" for f in ("x", "y", "cos", "sin", "vx", "vy", "turn", "alive")
    )
    with pytest.raises(RuntimeError, match="reset"):
        env.state()
