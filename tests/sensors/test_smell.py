"""The smell sensor against distances worked out by hand: around a wall's end rather than
through it, exact in the open, following items that are eaten, come back or move."""

import math
import pickle

import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.build.builder import Episode
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.sensors.scent import ScentField
from flatland_ma.sensors.smell import Smell
from flatland_ma.world.entities import Item

SPREAD = 100.0
HEAD_RADIUS = 4.0
"""The default head's radius: nostrils on the head sit on its rim."""
# A wall down from the top of the 300 x 300 room with a gap below it, or up from the
# bottom with a gap above it: its box spans x 145..155, and its ends reach 5 beyond its
# end points (half its thickness).
GAP_BELOW = {"start": [150, 100], "end": [150, 300], "thickness": 10}  # y 95..305
GAP_ABOVE = {"start": [150, 0], "end": [150, 200], "thickness": 10}  # y -5..205


def _env(items=(), walls=(), n_agents=1, **smell):
    sensor = {"type": "smell", "spread": SPREAD, **smell}
    return flatland_ma.parallel_env(
        "fruits_poisons" if n_agents == 1 else "fruits_poisons_multi",
        obstacles=[],
        items=list(items),
        walls=list(walls),
        agent={"sensors": [sensor]},
    )


def _food(*positions, name="food"):
    return {"name": name, "color": "orange", "positions": [list(p) for p in positions]}


def _episode(env) -> Episode:
    assert env.episode is not None, "reset first"
    return env.episode


def _sensor(env, k: int = 0) -> Smell:
    sensor = _episode(env).sensors.cameras[k]
    assert isinstance(sensor, Smell)
    return sensor


def _field(env, k: int = 0) -> ScentField:
    field = _sensor(env, k).field
    assert field is not None, "not attached"
    return field


def _array(observation) -> np.ndarray:
    assert isinstance(observation, np.ndarray)
    return observation


def _smell(env, x, y, heading, seed=0) -> np.ndarray:
    env.reset(seed=seed)
    return _smell_again(env, x, y, heading)


def _smell_again(env, x, y, heading) -> np.ndarray:
    episode = _episode(env)
    episode.world.place(episode.bodies[0], x, y, heading)
    episode.sensors.observe()
    return _array(episode.sensors.observation(0))


def _exact(x, y, heading, item):
    """What each nostril smells of ``item`` in the open: exp of minus the straight line."""
    return [math.exp(-math.dist(n, item) / SPREAD) for n in _nostrils(x, y, heading)]


def _nostrils(x, y, heading, reach=10.0, angle=math.pi / 4):
    """Left, then right nostril of an agent of radius ``reach`` at (x, y)."""
    return [
        (x + reach * math.cos(heading + side * angle), y + reach * math.sin(heading + side * angle))
        for side in (1, -1)
    ]


def _distance(strength):
    return -SPREAD * math.log(float(strength))


def _around_the_end(p, q, corners):
    """The way from p to q over the wall's end: to its near corner, across, on to q."""
    near, far = corners
    return math.dist(p, near) + math.dist(near, far) + math.dist(far, q)


@pytest.mark.parametrize("cell", [None, 5.0, 2.5])
def test_food_behind_a_wall_is_smelled_round_its_end_by_the_nostril_on_that_side(cell):
    """The food is dead ahead, behind a wall whose end is up to the left: straight-line
    distances would be the same for both nostrils; round the wall's end, the left nostril
    is nearer. Each reading is exp(-d / spread) for d the way round the end, to within a
    cell (the default cell: the agent's radius, 10)."""
    extra = {} if cell is None else {"cell": cell}
    env = _env([_food((220, 100))], [GAP_ABOVE], **extra)
    left, right = _smell(env, 80.0, 100.0, 0.0)[:, 0]
    assert left > right > 0.0
    ends = ((145.0, 205.0), (155.0, 205.0))
    tolerance = cell if cell is not None else 10.0
    for strength, nostril in zip((left, right), _nostrils(80.0, 100.0, 0.0)):
        by_hand = _around_the_end(nostril, (220.0, 100.0), ends)
        assert _distance(strength) == pytest.approx(by_hand, abs=tolerance)
        assert _distance(strength) > math.dist(nostril, (220.0, 100.0)) + 90.0  # not through


def test_the_mirrored_room_smells_stronger_on_the_right():
    env = _env([_food((220, 200))], [GAP_BELOW])
    left, right = _smell(env, 80.0, 200.0, 0.0)[:, 0]
    assert right > left > 0.0
    ends = ((145.0, 95.0), (155.0, 95.0))
    for strength, nostril in zip((left, right), _nostrils(80.0, 200.0, 0.0)):
        by_hand = _around_the_end(nostril, (220.0, 200.0), ends)
        assert _distance(strength) == pytest.approx(by_hand, abs=10.0)


def test_in_the_open_the_scent_is_exp_of_the_straight_distance():
    env = _env([_food((200, 150))])
    reading = _smell(env, 100.0, 150.0, math.pi / 2)  # heading north, the food east
    expected = [
        math.exp(-math.dist(n, (200, 150)) / SPREAD) for n in _nostrils(100, 150, math.pi / 2)
    ]
    assert reading[:, 0] == pytest.approx(expected, rel=1e-5)
    assert reading[1, 0] > reading[0, 0]  # the right nostril is the nearer
    # Between cell centres too: the reading changes smoothly as the agent moves.
    moved = _smell_again(env, 101.3, 150.7, math.pi / 2)
    expected = [
        math.exp(-math.dist(n, (200, 150)) / SPREAD) for n in _nostrils(101.3, 150.7, math.pi / 2)
    ]
    assert moved[:, 0] == pytest.approx(expected, rel=1e-5)


def test_the_scent_follows_an_item_moved_hidden_and_shown():
    env = _env([_food((200, 150))])
    before = _smell(env, 100.0, 150.0, math.pi / 2)
    world = _episode(env).world
    (item,) = world.of_type(Item)
    field = _field(env)
    searches = field.searches
    world.move_static(item, 20.0, 150.0)  # now west of the agent: the left nostril's side
    after = _smell_again(env, 100.0, 150.0, math.pi / 2)
    assert after[0, 0] > after[1, 0] and before[1, 0] > before[0, 0]
    expected = [
        math.exp(-math.dist(n, (20, 150)) / SPREAD) for n in _nostrils(100, 150, math.pi / 2)
    ]
    assert after[:, 0] == pytest.approx(expected, rel=1e-5)
    assert field.searches == searches + 1
    _smell_again(env, 120.0, 160.0, 0.0)  # the agent moved, the items did not
    assert field.searches == searches + 1
    world.withdraw(item)
    assert not _smell_again(env, 100.0, 150.0, math.pi / 2).any()
    world.restore(item)
    assert _smell_again(env, 100.0, 150.0, math.pi / 2) == pytest.approx(after)


def test_an_eaten_item_is_smelled_where_it_comes_back():
    env = _env([{"name": "food", "color": "orange", "reward": 1, "count": 1}])
    env.reset(seed=4)
    episode = _episode(env)
    (item,) = episode.world.of_type(Item)
    x, y = item.body.position
    start = (x - 40.0, y) if x > 60 else (x + 40.0, y)
    heading = 0.0 if x > 60 else math.pi
    episode.world.place(episode.bodies[0], *start, heading)
    searches = _field(env).searches
    eaten, reading = False, np.zeros(0)
    for _ in range(20):
        observations, rewards, *_ = env.step({"agent_0": 0})  # forward, onto the item
        eaten, reading = rewards["agent_0"] > 0, _array(observations["agent_0"])
        if eaten:
            break
    assert eaten
    new = tuple(item.body.position)
    assert item.visible and math.dist(new, (x, y)) > 1.0
    body = episode.bodies[0].body
    assert reading[:, 0] == pytest.approx(_exact(*body.position, body.angle, new), rel=1e-5)
    assert _field(env).searches > searches


def test_no_items_smell_of_nothing_and_the_space_holds_every_reading():
    env = _env()
    space = env.observation_space("agent_0")
    assert isinstance(space, spaces.Box)
    assert space.shape == (2, 1) and space.dtype == np.float32
    assert (space.low == 0).all() and (space.high == 1).all()
    reading = _smell(env, 100.0, 100.0, 0.0)
    assert reading.dtype == np.float32 and not reading.any() and space.contains(reading)


def test_one_channel_per_source_in_order():
    items = [_food((40, 150), name="fruits"), _food((260, 150), name="poisons")]
    env = _env(items, sources=["poisons", "fruits"])
    assert env.observation_space("agent_0").shape == (2, 2)
    reading = _smell(env, 150.0, 150.0, math.pi / 2)  # heading north: fruits west (left)
    poisons, fruits = reading[:, 0], reading[:, 1]
    assert fruits[0] > fruits[1] and poisons[1] > poisons[0]
    assert fruits[0] == pytest.approx(poisons[1], rel=1e-5)  # the room is symmetric
    # Without sources, one channel smells the nearest item of any group.
    both = _smell(_env(items), 150.0, 150.0, math.pi / 2)[:, 0]
    assert both == pytest.approx([fruits[0], poisons[1]], rel=1e-5)


def test_nothing_is_smelled_from_range_on():
    env = _env([_food((200, 150))], range=95.0)
    near = _smell(env, 110.0, 150.0, 0.0)  # nostrils ~83 from the food
    far = _smell_again(env, 20.0, 150.0, 0.0)  # ~173
    assert near.all() and not far.any()


def test_a_nostril_inside_a_wall_smells_from_beside_it():
    env = _env([_food((220, 100))], [GAP_ABOVE], nostril_distance=25.0)
    reading = _smell(env, 136.0, 100.0, 0.0)  # facing the wall, nostrils 8.7 deep in it
    field = _field(env)
    for x, y in _sensor(env).nostrils():
        assert 145 < x < 155 and field.grid.blocked[field.grid.cell_of(x, y)]
    assert reading.all() and (reading <= 1).all()
    ends = ((145.0, 205.0), (155.0, 205.0))
    for strength, (_, y) in zip(reading[:, 0], _sensor(env).nostrils()):
        by_hand = _around_the_end((145.0, y), (220.0, 100.0), ends)  # from the wall's face
        assert _distance(strength) == pytest.approx(by_hand, abs=15.0)


def test_agents_share_one_field_searched_once_per_change():
    env = _env(n_agents=4, items=[{"name": "food", "color": "orange", "count": 3}])
    env.reset(seed=1)
    fields = {id(_field(env, k)) for k in range(4)}
    assert len(fields) == 1
    field = _field(env)
    searches = field.searches
    env.step({a: 1 for a in env.agents})  # everyone turns: no item changes
    assert field.searches == searches


def test_smell_faults_are_located():
    with pytest.raises(ScenarioError) as info:
        flatland_ma.load_scenario(
            "fruits_poisons", agent={"sensors": [{"type": "smell", "sources": ["apples"]}]}
        )
    problem = str(info.value.problems[0])
    assert "agent.sensors[0].sources[0]" in problem and "fruits" in problem
    for bad in ({"sources": ["fruits", "fruits"]}, {"nostril_angle": 0}, {"spread": 0}):
        with pytest.raises(ScenarioError) as info:
            flatland_ma.load_scenario(
                "fruits_poisons", agent={"sensors": [{"type": "smell", **bad}]}
            )
        assert "agent.sensors[0]" in str(info.value.problems[0])


def test_the_parallel_api_holds_with_smell_beside_a_camera():
    sensors = [{"type": "camera", "rays": 16}, {"type": "smell", "sources": ["fruits", "poisons"]}]
    env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors})
    space = env.observation_space("agent_0")
    assert isinstance(space, spaces.Dict) and space["smell"].shape == (2, 2)
    parallel_api_test(env)


def _rollout(seed, steps=120):
    env = flatland_ma.parallel_env(
        "fruits_poisons", agent={"sensors": [{"type": "smell", "sources": ["fruits", "poisons"]}]}
    )
    observations, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    readings = [_array(observations["agent_0"])]
    for _ in range(steps):
        observations, *_ = env.step({"agent_0": int(rng.integers(3))})
        readings.append(_array(observations["agent_0"]))
    return np.array(readings), env


def test_the_same_seed_smells_the_same():
    first, env = _rollout(3)
    again, _ = _rollout(3)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, _rollout(4)[0])
    copy = pickle.loads(pickle.dumps(env))
    for action in (0, 0, 1, 0, 2, 0):
        a = _array(env.step({"agent_0": action})[0]["agent_0"])
        b = _array(copy.step({"agent_0": action})[0]["agent_0"])
        assert np.array_equal(a, b)


def test_the_sniffer_finds_food_behind_a_wall_where_random_play_does_not():
    from flatland_ma.policies import RandomPolicy, Sniffer, evaluate

    env = flatland_ma.parallel_env(
        "fruits_poisons",
        obstacles=[],
        walls=[{"start": [150, 0], "end": [150, 220], "thickness": 10}],
        items=[
            {
                "name": "food",
                "color": "orange",
                "reward": 10,
                "terminal": True,
                "respawn": "never",
                "positions": [[240, 80]],
            }
        ],
        agent={"sensors": [{"type": "smell"}], "spawn": {"area": [20, 20, 120, 280]}},
        episode={"max_steps": 250},
    )
    sniffer = evaluate(env, lambda a: Sniffer(env.spec, seed=0), episodes=6)
    random = evaluate(env, lambda a: RandomPolicy(env.action_space(a), seed=0), episodes=6)
    assert sum(r > 0 for r in sniffer.returns) >= 5
    assert sum(r > 0 for r in sniffer.returns) > sum(r > 0 for r in random.returns) + 2
    with pytest.raises(ValueError, match="has none"):
        Sniffer(flatland_ma.load_scenario("fruits_poisons"))


def test_nostrils_on_the_head_turn_with_it():
    """Food well north of an agent starting east-bound (within 30 of (150, 100)): with the
    head straight the left nostril smells it more; with the head turned to its left limit
    (90 degrees) the head faces the food, and each nostril, on the head's rim, smells what
    the straight line from it gives."""
    item = (150.0, 250.0)
    env = flatland_ma.parallel_env(
        "fruits_poisons",
        obstacles=[],
        items=[_food(item)],
        agent={
            "head": {},
            "sensors": [{"type": "smell", "spread": SPREAD, "mount": "head"}],
            "spawn": {"area": [120, 70, 180, 130], "heading": 0},
        },
    )

    def expected():
        head = _episode(env).bodies[0].links[0].body
        x, y = head.position
        nostrils = _nostrils(x, y, head.angle, reach=HEAD_RADIUS)
        return [math.exp(-math.dist(n, item) / SPREAD) for n in nostrils]

    straight = _array(env.reset(seed=0)[0]["agent_0"])
    assert straight[:, 0] == pytest.approx(expected(), rel=1e-4)
    assert straight[0, 0] > straight[1, 0] * 1.02
    head_left = env.action_index("head_left")
    for _ in range(60):
        turned = _array(env.step({"agent_0": head_left})[0]["agent_0"])
    episode = _episode(env)
    turn = episode.bodies[0].links[0].body.angle - episode.bodies[0].body.angle
    assert turn == pytest.approx(math.pi / 2, abs=0.05)
    assert turned[:, 0] == pytest.approx(expected(), rel=1e-4)
    assert turned[0, 0] == pytest.approx(turned[1, 0], rel=0.03)


def test_a_smell_on_the_head_needs_a_head():
    with pytest.raises(ScenarioError, match="head"):
        flatland_ma.parallel_env(
            "fruits_poisons", agent={"sensors": [{"type": "smell", "mount": "head"}]}
        )
