"""Bodies with parts: heads and arms on joints with limits, graspers that hold, slip and
let go, actions named per part (physics at the strongest settings: test_parts_stress)."""

import math

import gymnasium
import numpy as np
import pytest

import flatland_ma
from flatland_ma.world.entities import Obstacle
from tests.world_helpers import place

HEAD_ARM = {"head": {}, "arms": [{"mount": 0}], "camera": {"mount": "head"}}
OPEN = dict(obstacles=[], items=[])


def act(env, name, agent="agent_0", others="stay", steps=1):
    for _ in range(steps):
        env.step({a: env.action_index(name if a == agent else others, a) for a in env.agents})


def test_action_layouts_are_named_and_queryable():
    env = flatland_ma.parallel_env("fruits_poisons", agent=HEAD_ARM, **OPEN)
    assert env.action_names() == (
        "forward", "rotate_left", "rotate_right", "stay", "head_left", "head_right",
        "arm_left", "arm_right", "grasp", "release",
    )  # fmt: skip
    assert env.action_space("agent_0").n == 10 and env.action_index("grasp") == 8
    with pytest.raises(KeyError, match="no action 'jump'; actions: forward, rotate_left"):
        env.action_index("jump")
    two = {"arms": [{"mount": 30, "segments": [{}, {}]}, {"mount": -30, "grasper": None}]}
    # Two-joint arms swing their tips fast: more substeps keep them out of the walls.
    env = flatland_ma.parallel_env(
        "fruits_poisons", agent={**two, "actions": "continuous"}, physics={"substeps": 4}, **OPEN
    )
    joints = ("arm0_joint0", "arm0_joint1", "arm1_joint0")
    assert env.action_names() == ("longitudinal", "lateral", "angular", *joints, "arm0_grip")
    assert env.action_space("agent_0").shape == (7,)
    plain = flatland_ma.parallel_env("fruits_poisons")
    assert plain.action_space("agent_0").n == 3  # the paper's body is unchanged


def test_gymnasium_and_aec_envs_name_their_actions_too():
    env = gymnasium.make("flatland_ma/FetchObject-v0").unwrapped
    names = flatland_ma.parallel_env("fetch_object").action_names()
    assert env.action_names() == names and "grasp" in names
    assert env.action_index("grasp") == names.index("grasp") < env.action_space.n
    with pytest.raises(KeyError, match="no action 'jump'"):
        env.action_index("jump")
    aec = flatland_ma.env("tug_of_war")  # through PettingZoo's wrappers
    assert aec.action_names("blue_1") == flatland_ma.parallel_env("tug_of_war").action_names()
    assert aec.action_index("head_left", "blue_1") == 4


def test_the_head_turns_within_its_limits_and_carries_the_camera():
    env = flatland_ma.parallel_env(
        "fruits_poisons", agent={**HEAD_ARM, "camera": {"mount": "head", "range": 500}}, **OPEN
    )
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    head = env.episode.bodies[0].head
    step = math.radians(env.spec.agent.head.turn_rate) * env.spec.physics.dt
    for k in range(1, 13):
        act(env, "head_left")
        expected = min(k * step, math.radians(90))
        assert head.angle_to_parent == pytest.approx(expected, abs=math.radians(1.5))
    # The camera looks along the head: the middle rays meet the north wall, 150 away.
    sensors = env.episode.sensors
    middle = sensors.distance[31:33]
    angles = sensors.cameras[0].angles[31:33]
    heading = env.episode.bodies[0].body.angle + head.angle_to_parent
    x, y = env.episode.bodies[0].body.position
    np.testing.assert_allclose(middle, (300 - y) / np.sin(heading + angles), rtol=1e-3)
    assert env.episode.bodies[0].body.position.x == pytest.approx(150.0, abs=0.5)


def test_arm_joints_move_as_commanded_and_stop_at_their_limits():
    arm = {"mount": 0, "segments": [{"min_angle": -30, "max_angle": 45}]}
    env = flatland_ma.parallel_env("fruits_poisons", agent={"arms": [arm]}, **OPEN)
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    joint = env.episode.bodies[0].joints[0]
    act(env, "arm_left", steps=3)
    assert joint.angle_to_parent == pytest.approx(math.radians(18), abs=math.radians(0.5))
    act(env, "arm_left", steps=20)
    assert joint.angle_to_parent == pytest.approx(math.radians(45), abs=math.radians(1))
    act(env, "arm_right", steps=40)
    assert joint.angle_to_parent == pytest.approx(math.radians(-30), abs=math.radians(1))
    act(env, "stay", steps=20)
    assert joint.angle_to_parent == pytest.approx(math.radians(-30), abs=math.radians(1))


def test_an_agent_does_not_collide_with_itself_and_its_arm_stops_at_walls():
    env = flatland_ma.parallel_env("fruits_poisons", agent=HEAD_ARM, **OPEN)
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    body = env.episode.bodies[0]
    act(env, "stay", steps=60)  # the head lies inside the base: no self-contact pushes it
    assert tuple(body.body.position) == pytest.approx((150.0, 150.0), abs=1e-6)
    assert body.touching == 0
    act(env, "forward", steps=40)  # arm first into the east wall
    tip = body.joints[0].body.local_to_world((env.spec.agent.arms[0].segments[0].length, 0))
    grip = env.spec.agent.arms[0].grasper.radius
    assert tip.x + grip <= 300.0 + 0.5
    assert body.body.position.x < 300 - 10 - 16


def test_other_agents_see_an_agents_parts():
    env = flatland_ma.parallel_env("fruits_poisons_multi", n_agents=2, agent=HEAD_ARM, **OPEN)
    env.reset(seed=0)
    place(env, 0, 100.0, 150.0, 0.0)
    place(env, 1, 150.0, 150.0, math.pi / 2)  # its arm points north, across agent 0's view
    act(env, "stay", others="stay")
    seen = set(env.episode.sensors.hit_entity[env.episode.sensors.slices[0]])
    parts = {p.index for p in env.episode.bodies[1].links}
    assert parts & seen
    own = {p.index for p in env.episode.bodies[0].links} | {env.episode.bodies[0].index}
    assert not own & seen


def ball_env(**ball):
    obstacle = {"shape": "circle", "position": [140, 150], "radius": 7, "movable": True,
                "mass": 0.5, "graspable": True, "tag": "ball", **ball}  # fmt: skip
    env = flatland_ma.parallel_env(
        "fruits_poisons", obstacles=[obstacle], items=[], agent={"arms": [{"mount": 0}]}
    )
    env.reset(seed=0)
    place(env, 0, 100.0, 150.0, 0.0)
    ball = next(e for e in env.episode.world.entities if isinstance(e, Obstacle))
    return env, ball, env.episode.bodies[0].hands[0]


def test_a_closed_hand_holds_what_it_touches_carries_it_and_lets_go():
    env, ball, hand = ball_env()
    act(env, "grasp")
    assert hand.closed and hand.held is None  # not touching yet
    act(env, "forward", steps=2)
    assert hand.held is ball
    start = tuple(ball.body.position)
    act(env, "rotate_left", steps=9)  # a quarter turn: the ball swings round with the arm
    base = env.episode.bodies[0].body
    bx, by = ball.body.position
    assert math.degrees(base.angle) > 80 and math.dist(start, (bx, by)) > 30
    grip = hand.segment.body.local_to_world(hand.shape.offset)
    assert math.dist(grip, (bx, by)) < 3.0 + 7.0 + hand.break_distance  # still in hand
    act(env, "release")
    assert hand.held is None and not hand.closed
    act(env, "stay", steps=20)  # it rolls on a little, and floor friction stops it
    rest = tuple(ball.body.position)
    act(env, "rotate_right", steps=9)
    assert math.dist(ball.body.position, rest) < 10.0  # left behind (held, it would go ~40)


def test_a_hold_breaks_on_an_object_too_heavy_to_drag():
    env, ball, hand = ball_env(mass=50.0, floor_friction=1.0)  # drags with 50,000
    act(env, "grasp")
    act(env, "forward", steps=2)
    assert hand.held is ball
    act(env, "rotate_right", steps=15)
    assert hand.held is None and not hand.closed and hand.cooldown > 0
    assert math.dist(ball.body.position, (140, 150)) < 2.0


def test_a_tug_from_another_agent_breaks_a_hold():
    env = flatland_ma.parallel_env("tug_of_war")
    env.reset(seed=0)
    ball = next(e for e in env.episode.world.entities if isinstance(e, Obstacle))
    bodies = env.episode.bodies
    place(env, 0, 215.0, 150.0, 0.0)
    place(env, 2, 285.0, 150.0, math.pi)
    place(env, 1, 250.0, 40.0, 0.0)
    place(env, 3, 250.0, 240.0, 0.0)
    grasp, forward = env.action_index("grasp"), env.action_index("forward")
    hands = [bodies[0].hands[0], bodies[2].hands[0]]
    for _ in range(3):
        env.step(
            {a: grasp if a in ("red_0", "blue_0") else env.action_index("stay") for a in env.agents}
        )
        env.step(
            {
                a: forward if a in ("red_0", "blue_0") else env.action_index("stay")
                for a in env.agents
            }
        )
    assert all(h.held is ball for h in hands)
    # Both turn round and walk away from each other: one hold at least must give.
    left = env.action_index("rotate_left")
    for t in range(60):
        step = left if t < 18 else forward
        env.step(
            {a: step if a in ("red_0", "blue_0") else env.action_index("stay") for a in env.agents}
        )
        if any(h.held is None for h in hands):
            break
    assert any(h.held is None and h.cooldown > 0 for h in hands)


def test_a_key_object_touching_its_door_opens_it():
    env = flatland_ma.parallel_env("key_carry")
    env.reset(seed=0)
    key = next(e for e in env.episode.world.entities if isinstance(e, Obstacle))
    (door,) = env.episode.doors
    key.body.position = (225.0, 125.0)
    key.body.velocity = (200.0, 0.0)
    env.episode.world.space.reindex_shapes_for_body(key.body)
    act(env, "stay", steps=5)
    assert door.is_open


def test_deliveries_reward_the_zone_team_take_from_the_other_and_end():
    env = flatland_ma.parallel_env("tug_of_war")
    env.reset(seed=0)
    ball = next(e for e in env.episode.world.entities if isinstance(e, Obstacle))
    ball.body.position = (30.0, 150.0)  # in the red team's area
    env.episode.world.space.reindex_shapes_for_body(ball.body)
    stay = env.action_index("stay")
    _, rewards, terminations, _, infos = env.step({a: stay for a in env.agents})
    assert rewards == {"red_0": 10.0, "red_1": 10.0, "blue_0": -10.0, "blue_1": -10.0}
    assert all(terminations.values()) and env.agents == []
    assert infos["red_0"]["deliveries"] == 1 and infos["blue_0"]["deliveries"] == 0


def test_a_delivered_object_goes_back_where_it_started_when_play_goes_on():
    zone = {"rect": [220, 100, 300, 200], "accepts": "ball", "delivery_reward": 3.0}
    env = flatland_ma.parallel_env(
        "fruits_poisons",
        obstacles=[
            {"shape": "circle", "position": [140, 150], "radius": 7, "movable": True, "tag": "ball"}
        ],
        items=[],
        zones=[zone],
    )
    env.reset(seed=0)
    ball = next(e for e in env.episode.world.entities if isinstance(e, Obstacle))
    ball.body.position = (250.0, 150.0)
    env.episode.world.space.reindex_shapes_for_body(ball.body)
    _, rewards, terminations, _, _ = env.step({"agent_0": 1})
    assert rewards["agent_0"] == 3.0 and not terminations["agent_0"]
    assert tuple(ball.body.position) == (140.0, 150.0)
