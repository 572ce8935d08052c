"""Doors block agents and rays until opened: by touch, by a key held, by a switch; hinged
doors swing when pushed."""

import math

import flatland_ma
from flatland_ma.world.entities import SlidingDoor
from tests.world_helpers import doors, place, walk

DIVIDED = dict(
    arena={"size": [400, 250]},
    walls=[{"start": [250, 0], "end": [250, 250], "thickness": 8}],
    obstacles=[],
)


def divided(door, items_=(), zones=()):
    return flatland_ma.parallel_env(
        "fruits_poisons", doors=[door], items=list(items_), zones=list(zones), **DIVIDED
    )


DOOR_LINE = {"start": [250, 100], "end": [250, 150]}


def test_a_closed_door_blocks_rays_and_opens_when_touched():
    env = divided({**DOOR_LINE, "color": "red"})
    env.reset(seed=0)
    (door,) = doors(env)
    place(env, 0, 200.0, 125.0, 0.0)
    env.episode.sensors.observe()
    sensors = env.episode.sensors
    middle = sensors.hit_entity[sensors.slices[0]][32]
    assert middle == door.index and not door.is_open
    # The door is as thick as the arena's walls (10): its face is at x = 245.
    angle = sensors.cameras[0].angles[32]
    assert abs(sensors.distance[32] - 45.0 / math.cos(angle)) < 1e-9
    walk(env, 10)  # walk into it: it opens
    assert door.is_open and not door.visible
    walk(env, 15)
    assert env.episode.bodies[0].body.position.x > 260  # through the doorway


def test_a_locked_door_opens_only_to_the_holder_of_its_key():
    key = {
        "name": "key",
        "color": "gold",
        "key": True,
        "respawn": "never",
        "positions": [[150, 125]],
    }
    env = divided({**DOOR_LINE, "state": "locked", "key": "key"}, items_=[key])
    env.reset(seed=0)
    (door,) = doors(env)
    place(env, 0, 200.0, 200.0, -math.pi / 2)
    walk(env, 12, agent="agent_0")  # down to y ~ 125, then east into the door
    place(env, 0, 225.0, 125.0, 0.0)
    walk(env, 8)
    assert not door.is_open  # no key: pushing does nothing
    assert env.episode.bodies[0].body.position.x < 250 - 4 - 10 + 1
    place(env, 0, 180.0, 125.0, math.pi)  # fetch the key, behind the agent
    _, infos = walk(env, 6)
    assert infos["agent_0"]["keys"] == ("key",) and infos["agent_0"]["key"] == 1
    place(env, 0, 225.0, 125.0, 0.0)
    walk(env, 8)
    assert door.is_open


def test_a_switched_door_opens_while_someone_stands_on_the_switch():
    plate = {"name": "plate", "rect": [40, 40, 90, 90]}
    for latch in (True, False):
        env = divided({**DOOR_LINE, "switch": "plate", "latch": latch}, zones=[plate])
        env.reset(seed=0)
        (door,) = doors(env)
        place(env, 0, 220.0, 125.0, 0.0)
        walk(env, 5)
        assert not door.is_open  # touching does not open a switched door
        place(env, 0, 65.0, 65.0, 0.0)
        walk(env, 1, action=1)
        assert door.is_open
        place(env, 0, 150.0, 200.0, 0.0)
        walk(env, 1, action=1)
        assert door.is_open == latch


def test_a_hinged_door_swings_when_pushed_and_stays():
    env = divided({**DOOR_LINE, "kind": "hinged"})
    env.reset(seed=0)
    (door,) = doors(env)
    start = door.body.angle
    place(env, 0, 200.0, 128.0, 0.0)
    walk(env, 25)
    assert abs(door.body.angle - start) > math.radians(45)
    assert env.episode.bodies[0].body.position.x > 255  # it went through
    swung = door.body.angle
    walk(env, 20, action=1)  # turn in place, away from the door
    assert abs(door.body.angle - swung) < math.radians(5)  # hinge friction holds it
    assert abs(door.body.angle - start) <= door.swing + 1e-6


def test_doors_in_room_openings_and_grid_rooms():
    room = {
        "rect": [50, 50, 200, 200],
        "openings": [{"side": "east", "width": 40, "door": {"color": "red"}}],
    }
    env = flatland_ma.parallel_env(
        "fruits_poisons",
        obstacles=[],
        rooms=[room],
        items=[],
        agent={"spawn": {"area": [70, 70, 180, 180]}},
    )
    env.reset(seed=0)
    (door,) = doors(env)
    # The opening is centred on the east side (y = 125) and 40 wide: the door spans it.
    assert tuple(door.body.position) == (200.0, 105.0)
    assert abs(door.body.angle - math.pi / 2) < 1e-9
    ys = [door.body.local_to_world(v).y for v in door.shapes[0].get_vertices()]
    assert min(ys) == 105.0 and abs(max(ys) - 145.0) < 1e-9
    gen = {"generator": "grid_rooms", "rows": 2, "cols": 3, "doors": "closed"}
    env = flatland_ma.parallel_env("fruits_poisons", obstacles=[], layout={"generators": [gen]})
    env.reset(seed=0)
    assert len(doors(env)) == 2 * 2 + 1 * 3  # one per shared wall
    assert all(isinstance(d, SlidingDoor) and not d.is_open for d in doors(env))
