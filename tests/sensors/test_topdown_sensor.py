"""The top-down sensor against pictures worked out by hand, pixel by pixel, and against
pymunk's own point and segment queries in a furnished room.

Most scenes use a 20 x 20 image over 200 x 200 units (10 units a pixel) around an agent
at (122, 150) in the 300 x 300 room of ``fruits_poisons``, with one extra wall standing
across the room from (175, 0) to (185, 300). In the mount's frame, pixel (row i, column
j) has its centre ``95 - 10 i`` units ahead and ``95 - 10 j`` units to the left.
"""

import math

import numpy as np
import pymunk
import pytest
from gymnasium.spaces import Box
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.build.builder import Episode
from flatland_ma.scenario.colors import parse_color
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.sensors.semantic import SEMANTIC_KINDS
from flatland_ma.world.entities import Item

AGENT_AT = (122.0, 150.0)
WALL = {"start": [180, 50], "end": [180, 250], "thickness": 10, "color": "red"}
SMALL = {"type": "topdown", "size": 20, "extent": 200}
WALL_ID = SEMANTIC_KINDS.index("wall")


def _env(sensor=None, **overrides):
    overrides = {"obstacles": [], "items": [], **overrides}
    agent = {"sensors": [{**SMALL, **(sensor or {})}], **overrides.pop("agent", {})}
    return flatland_ma.parallel_env("fruits_poisons", **overrides, agent=agent)


def _episode(env) -> Episode:
    assert env.episode is not None, "reset the env first"
    return env.episode


def _observe(episode: Episode) -> np.ndarray:
    """Agent 0's picture of the world as it stands."""
    episode.sensors.observe()
    image = episode.sensors.observation(0)
    assert isinstance(image, np.ndarray)
    return image


def _look(env, heading, at=AGENT_AT, seed=0) -> np.ndarray:
    env.reset(seed=seed)
    episode = _episode(env)
    episode.world.place(episode.bodies[0], at[0], at[1], heading)
    return _observe(episode)


def _rgb(name):
    """A named colour as the sensor gives it."""
    return np.array(parse_color(name), np.float32)


# -- where things are drawn ---------------------------------------------------------------


@pytest.mark.parametrize(
    "heading, ahead, axis, index, arena_rows",
    [
        # East: the wall's 10 units (x 175..185) hold the centre 177 = 122 + 95 - 10 * 4.
        (0.0, 0.0, "row", 4, []),
        # North: ahead is +y and left is -x; x = 122 - (95 - 10 j) = 177 at column 15.
        (math.pi / 2, 0.0, "column", 15, []),
        # West: the wall is behind; x = 122 - (95 - 10 i) = 177 at row 15.
        (math.pi, 0.0, "row", 15, []),
        # South: left is +x; x = 122 + 95 - 10 j = 177 at column 4.
        (-math.pi / 2, 0.0, "column", 4, []),
        # East with the agent on the bottom edge: centres 100 + 95 - 10 i ahead, so
        # x = 317 - 10 i: 177 at row 14, and 307, in the arena's east wall, at row 1.
        (0.0, 0.5, "row", 14, [1]),
    ],
)
def test_a_wall_at_a_known_distance_fills_exactly_the_expected_row_or_column(
    heading, ahead, axis, index, arena_rows
):
    env = _env({"channels": ["rgb", "semantic"], "ahead": ahead}, walls=[WALL])
    image = _look(env, heading)
    assert image.shape == (20, 20, 4) and image.dtype == np.float32
    red = np.zeros((20, 20), bool)
    if axis == "row":
        red[index, :] = True
    else:
        red[:, index] = True
    wall = red.copy()
    wall[arena_rows, :] = True
    agent = np.zeros((20, 20), bool)
    # Its disc of radius 10 holds the four centres 7.07 from its own: in the middle, or
    # on the bottom row.
    agent[slice(9, 11) if ahead == 0.0 else slice(19, 20), 9:11] = True
    assert np.array_equal(image[..., 3] == WALL_ID, wall)
    assert np.array_equal(image[..., 3] == SEMANTIC_KINDS.index("agent"), agent)
    assert np.all(image[..., 3][~wall & ~agent] == 0)
    np.testing.assert_array_equal(image[red, :3], np.tile(_rgb("red"), (20, 1)))
    arena = np.array(env.spec.arena.wall.color, np.float32)
    np.testing.assert_array_equal(image[wall & ~red, :3], np.tile(arena, (len(arena_rows) * 20, 1)))
    body_colour = np.array(_episode(env).bodies[0].color, np.float32)
    np.testing.assert_allclose(image[agent, :3], np.tile(body_colour, (agent.sum(), 1)))
    assert np.all(image[~wall & ~agent, :3] == 0)


def test_the_arena_walls_frame_a_view_that_covers_the_whole_room():
    """32 x 32 pixels of 10 units over 320 x 320 around the centre (150, 150): the arena's
    walls (10 thick, outside 0..300) hold the outer ring of centres (+-155) whichever way
    the agent faces; turned by a radian, the corners fall outside the room."""
    env = _env({"size": 32, "extent": 320, "channels": ["semantic"]})
    turned = _look(env, 1.0, at=(150.0, 150.0))[..., 0]
    assert turned[0, 0] == turned[0, -1] == turned[-1, 0] == turned[-1, -1] == 0
    for heading in (0.0, math.pi / 2, math.pi, -math.pi / 2):
        image = _look(env, heading, at=(150.0, 150.0))[..., 0]
        ring = np.ones((32, 32), bool)
        ring[1:-1, 1:-1] = False
        assert np.array_equal(image == WALL_ID, ring)


def test_an_item_at_a_known_offset_lands_on_its_pixel_in_its_colour():
    # Heading north from (150, 150): 45 ahead and 15 to the right is (165, 195), the
    # centre of pixel (5, 11); its neighbours' centres are 10 away, beyond its radius 6.
    items = [{"name": "gem", "color": "orange", "radius": 6, "positions": [[165, 195]]}]
    env = _env({"channels": ["rgb", "semantic"]}, items=items)
    for heading, pixel in ((math.pi / 2, (5, 11)), (0.0, (8, 5))):
        # Heading east, the item is 15 ahead (row 8) and 45 to the left (column 5).
        image = _look(env, heading, at=(150.0, 150.0))
        item = image[..., 3] == SEMANTIC_KINDS.index("item")
        assert list(zip(*np.nonzero(item))) == [pixel]
        np.testing.assert_array_equal(image[pixel][:3], _rgb("orange"))


def test_another_agent_and_a_movable_box_are_drawn_where_they_stand():
    obstacles = [
        # A movable box 20 x 20 centred 40 ahead and 40 to the left (heading north from
        # (150, 150): at (110, 190)): centres 35 and 45 ahead, 35 and 45 left.
        {"shape": "box", "position": [110, 190], "size": [20, 20], "movable": True,
         "color": "cyan"},
    ]  # fmt: skip
    env = _env(
        {"channels": ["rgb", "semantic"]}, obstacles=obstacles, n_agents=2, agent={"radius": 8}
    )
    env.reset(seed=0)
    episode = _episode(env)
    episode.world.place(episode.bodies[0], 150.0, 150.0, math.pi / 2)
    # The other agent 25 behind and 35 to the right: (185, 125), the centre of pixel
    # (12, 13); its radius 8 holds no other centre (the nearest are 10 away).
    episode.world.place(episode.bodies[1], 185.0, 125.0, 0.3)
    image = _observe(episode)
    agent = SEMANTIC_KINDS.index("agent")
    others = {(int(i), int(j)) for i, j in zip(*np.nonzero(image[..., 3] == agent))}
    assert others == {(9, 9), (9, 10), (10, 9), (10, 10), (12, 13)}
    np.testing.assert_allclose(image[12, 13, :3], episode.bodies[1].color)
    box = image[..., 3] == SEMANTIC_KINDS.index("obstacle")
    expected = np.zeros((20, 20), bool)
    expected[5:7, 5:7] = True
    assert np.array_equal(box, expected)
    np.testing.assert_array_equal(image[5, 5, :3], _rgb("cyan"))


def test_a_head_mount_turns_the_picture_with_the_head():
    env = _env({"channels": ["semantic"], "mount": "head"}, walls=[WALL], agent={"head": {}})
    env.reset(seed=0)
    episode = _episode(env)
    base = episode.bodies[0]
    episode.world.place(base, AGENT_AT[0], AGENT_AT[1], 0.0)
    head = base.head.body  # turned left: the wall is on the right
    head.angle, head.position = math.pi / 2, AGENT_AT  # pymunk turns it about its centre
    episode.world.space.reindex_shapes_for_body(head)
    image = _observe(episode)[..., 0]
    assert np.all(image[:, 15] == WALL_ID) and np.sum(image == WALL_ID) == 20


def test_a_map_held_north_up_is_the_turned_map_of_an_agent_facing_north_whichever_way_it_faces():
    items = [{"name": "gem", "color": "orange", "radius": 6, "positions": [[165, 195]]}]
    sensor = {"channels": ["rgb", "semantic"]}
    north = _look(_env(sensor, items=items), math.pi / 2, at=(150.0, 150.0))
    held = _env({**sensor, "turned": False}, items=items)
    assert held.spec.agent.sensors[0].turned is False
    for heading in (math.pi / 2, 0.0, 2.0, -math.pi / 2):
        image = _look(held, heading, at=(150.0, 150.0))
        np.testing.assert_array_equal(image, north)
        item = image[..., 3] == SEMANTIC_KINDS.index("item")
        assert list(zip(*np.nonzero(item))) == [(5, 11)]  # 45 north, 15 east
    east = _look(_env(sensor, items=items), 0.0, at=(150.0, 150.0))
    assert not np.array_equal(east, north)  # the turned map does turn


# -- what the agent sees -------------------------------------------------------------------


def test_masked_pixels_behind_a_wall_are_blanked_and_its_face_is_seen():
    """Heading east, the wall (x 175 to 185) holds row 4's centres (x 177), which are seen,
    being in the wall itself; rows 0-3 (x 187 and beyond) lie behind it, rows 5-19 in
    front. An item behind the wall at (207, 155), pixel (1, 9), is drawn unmasked and
    blanked masked; an item in front, at (157, 155), pixel (6, 9), hides nothing."""
    items = [{"name": "gem", "color": "orange", "radius": 4, "positions": [[207, 155], [157, 155]]}]
    channels = ["rgb", "semantic", "visibility"]
    plain = _look(_env({"channels": channels}, walls=[WALL], items=items), 0.0)
    masked = _look(_env({"channels": channels, "masked": True}, walls=[WALL], items=items), 0.0)
    seen = np.ones((20, 20), bool)
    seen[:4] = False
    assert np.array_equal(plain[..., 4] == 1, seen)
    assert np.array_equal(masked[..., 4] == 1, seen)
    np.testing.assert_array_equal(plain[1, 9, :3], _rgb("orange"))
    assert np.all(masked[:4, :, :4] == 0)  # everything behind, the arena wall too
    assert np.all(plain[:4, :, 3] != WALL_ID) and plain[1, 9, 3] == SEMANTIC_KINDS.index("item")
    np.testing.assert_array_equal(masked[4:], plain[4:])
    assert np.all(masked[4, :, 3] == WALL_ID) and masked[6, 9, 3] == SEMANTIC_KINDS.index("item")


def test_a_field_of_view_blanks_what_is_behind_the_agent():
    """With fov 180, the centres behind the heading (rows 10-19, 5 to 95 units back)
    are outside it; the obstacle disc 50 ahead hides the pixels straight behind it."""
    obstacles = [{"shape": "circle", "position": [172, 150], "radius": 8}]
    sensor = {"channels": ["visibility"], "fov": 180, "masked": True}
    image = _look(_env(sensor, obstacles=obstacles), 0.0)[..., 0]
    assert np.all(image[10:] == 0)
    # Columns 9 and 10 are 5 units to the side of the disc's centre line: its centres 45
    # and 55 ahead (rows 5 and 4) lie in the disc (7.1 from its centre), and are seen;
    # those farther (rows 0-3, 65 ahead and more) have the disc on their line of sight.
    assert np.all(image[0:4, 9:11] == 0)
    assert np.all(image[4:10, 9:11] == 1)
    assert np.all(image[:10, :3] == 1) and np.all(image[:10, -3:] == 1)


def test_unmasked_pictures_ignore_visibility_and_the_field_of_view():
    env = _env({"fov": 90}, walls=[WALL])
    image = _look(env, 0.0)
    assert np.all(image[4] == _rgb("red"))  # the wall row, as without a fov


# -- against pymunk's own queries ----------------------------------------------------------


def _pixel_centres(env, k, size, extent, ahead):
    """World coordinates of every pixel centre of sensor k, and of its mount."""
    sensors = _episode(env).sensors
    body = sensors.carriers[k].body
    (ox, oy), angle = body.position, body.angle
    side = extent / size
    steps = (size / 2 - np.arange(size) - 0.5) * side
    forward, left = np.meshgrid(ahead * extent + steps, steps, indexing="ij")
    c, s = math.cos(angle), math.sin(angle)
    world = np.stack([ox + forward * c - left * s, oy + forward * s + left * c], axis=-1)
    return world, (ox, oy)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pictures_match_pymunk_point_and_segment_queries_in_a_furnished_room(seed):
    """In fruits_poisons (four obstacles, twenty items) and a second agent, each pixel
    shows the entity whose shape pymunk finds at its centre, and is seen exactly when
    pymunk finds no wall, obstacle or other agent on the line of sight to its centre, but
    the shapes that hold the centre."""
    size, extent = 32, 200.0
    sensor = {"type": "topdown", "size": size, "extent": extent,
              "channels": ["semantic", "visibility"], "ahead": 0.2}  # fmt: skip
    env = flatland_ma.parallel_env("fruits_poisons", n_agents=2, agent={"sensors": [sensor]})
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(15):
        env.step({a: env.action_space(a).sample() for a in env.agents})
    episode = _episode(env)
    world = episode.world
    x, y = rng.uniform(40, 260, 2)
    while not world.is_free(x, y, 12.0):
        x, y = rng.uniform(40, 260, 2)
    world.place(episode.bodies[0], x, y, rng.uniform(-3, 3))
    image = _observe(episode)
    kinds = episode.sensors.kinds
    centres, mount = _pixel_centres(env, 0, size, extent, 0.2)
    checked = 0
    for i in range(size):
        for j in range(size):
            point = tuple(centres[i, j])
            found = [
                q
                for q in world.space.point_query(point, 0.0, pymunk.ShapeFilter())
                if q.shape in world.entity_of_shape and world.entity_of_shape[q.shape].visible
            ]
            if any(abs(q.distance) < 1e-6 for q in found):
                continue  # on an outline: either answer is right
            holding = {q.shape for q in found if q.distance < 0}
            inside = max((world.entity_of_shape[shape].index for shape in holding), default=-1)
            hits = [
                q
                for q in world.space.segment_query(mount, point, 0.0, pymunk.ShapeFilter())
                if _hides(world, q.shape) and q.shape not in holding
            ]
            if any(abs(q.alpha - 1.0) < 1e-9 for q in hits):
                continue  # grazing the pixel centre
            seen = not hits
            assert image[i, j, 0] == kinds[inside], (i, j, inside)
            assert image[i, j, 1] == float(seen), (i, j)
            checked += 1
    assert checked > 0.95 * size * size
    assert len(np.unique(image[..., 0])) >= 4 and 0 < image[..., 1].sum() < size * size


def _hides(world, shape) -> bool:
    entity = world.entity_of_shape.get(shape)
    if entity is None or not entity.visible or isinstance(entity, Item):
        return False
    return entity.owner != 0


# -- contracts -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "sensor, width, high",
    [
        ({"type": "topdown"}, 3, 1.0),
        ({"type": "topdown", "channels": ["semantic"]}, 1, 5.0),
        ({"type": "topdown", "channels": ["semantic"], "semantic": "onehot"}, 6, 1.0),
        ({"type": "topdown", "channels": ["visibility", "rgb"], "masked": True}, 4, 1.0),
        ({"type": "topdown", "size": 7, "noise": {"gaussian": 0.1, "dropout": 0.1}}, 3, 1.0),
    ],
)
def test_observations_lie_in_the_space_with_its_dtype(sensor, width, high):
    env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": [sensor]})
    space = env.observation_space("agent_0")
    assert isinstance(space, Box)
    size = sensor.get("size", 32)
    assert space.shape == (size, size, width) and space.dtype == np.float32
    assert float(space.high.max()) == high and float(space.low.min()) == 0.0
    observations, _ = env.reset(seed=1)
    for _ in range(10):
        for observation in observations.values():
            assert isinstance(observation, np.ndarray) and observation.dtype == np.float32
            assert space.contains(observation)
        observations, *_ = env.step({a: env.action_space(a).sample() for a in env.agents})
    assert any(np.any(np.asarray(o) > 0) for o in observations.values())


def test_the_parallel_api_holds_with_a_topdown_beside_a_camera():
    sensors = [{"type": "camera", "rays": 16}, {"type": "topdown", "size": 16, "masked": True}]
    parallel_api_test(flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors}))
    env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors})
    observations, _ = env.reset(seed=0)
    assert observations["agent_1"]["topdown"].shape == (16, 16, 3)


def test_the_same_seed_gives_the_same_pictures():
    sensor = {"type": "topdown", "masked": True, "channels": ["rgb", "visibility"]}

    def run(seed):
        env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": [sensor]})
        observations, _ = env.reset(seed=seed)
        actions = np.random.default_rng(7)
        frames = [observations]
        for _ in range(30):  # forward, left, right: Discrete(3)
            frames.append(env.step({a: int(actions.integers(3)) for a in env.agents})[0])
        return [{k: np.asarray(o) for k, o in frame.items()} for frame in frames]

    first, second, other = run(4), run(4), run(5)
    assert all(np.array_equal(a[k], b[k]) for a, b in zip(first, second, strict=True) for k in a)
    assert not all(np.array_equal(a[k], b[k]) for a, b in zip(first, other) for k in a)


@pytest.mark.parametrize(
    "bad, key",
    [
        ({"size": 0}, "size"),
        ({"size": 2.5}, "size"),
        ({"extent": 0}, "extent"),
        ({"ahead": 0.7}, "ahead"),
        ({"channels": ["depth"]}, "channels"),
        ({"channels": []}, "channels"),
        ({"masked": "yes"}, "masked"),
        ({"fov": 0}, "fov"),
        ({"mount": "tail"}, "mount"),
    ],
)
def test_bad_topdown_values_are_located(bad, key):
    with pytest.raises(ScenarioError) as info:
        flatland_ma.load_scenario("fruits_poisons", agent={"sensors": [{"type": "topdown", **bad}]})
    assert str(info.value.problems[0]).startswith(f"<overrides>: agent.sensors[0].{key}")


def test_repeated_channels_and_a_head_mount_without_a_head_are_refused():
    for sensor, words in (
        ({"type": "topdown", "channels": ["rgb", "rgb"]}, "once"),
        ({"type": "topdown", "mount": "head"}, "needs a 'head'"),
    ):
        with pytest.raises(ScenarioError, match=words):
            flatland_ma.load_scenario("fruits_poisons", agent={"sensors": [sensor]})
