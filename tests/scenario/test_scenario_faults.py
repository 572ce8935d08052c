"""Each kind of fault in a scenario file is reported with the file, the line, the key path
and what was expected."""

import pytest

from tests.scenario_helpers import problems, write

KEY_DOOR = """\
arena: {size: [400, 250]}
walls:
  - {start: [250, 0], end: [250, 250], thickness: 8}
doors:
  - {start: [250, 105], end: [250, 145], state: locked, key: key}
agent:
  spawn: {area: [20, 20, 230, 230]}
"""
"""The west part of a split arena, where agents start; a locked door to the east part."""
SWITCH_DOOR = KEY_DOOR.replace("state: locked, key: key", "switch: plate")


@pytest.mark.parametrize(
    "text, line, path, words",
    [
        ("n_agents: '2'\n", 1, ("n_agents",), "valid integer"),
        ("n_agents: 2.5\n", 1, ("n_agents",), "valid integer"),
        ("n_agents: 0\n", 1, ("n_agents",), "greater than or equal to 1"),
        ("episode:\n  max_steps: -5\n", 2, ("episode", "max_steps"), "greater than or equal to 1"),
        ("agent:\n  camera:\n    rays: many\n", 3, ("agent", "camera", "rays"), "valid integer"),
        (
            "agent:\n  camera:\n    fov: 400\n",
            3,
            ("agent", "camera", "fov"),
            "less than or equal to 360",
        ),
        ("agent:\n  actions: teleport\n", 2, ("agent", "actions"), "'discrete' or 'continuous'"),
        ("arena:\n  size: [300]\n", 2, ("arena", "size"), "too few items"),
        ("arena:\n  size: [300, .nan]\n", 2, ("arena", "size", 1), "finite"),
        (
            "arena:\n  wall:\n    color: oragne\n",
            3,
            ("arena", "wall", "color"),
            "unknown colour name 'oragne' (did you mean 'orange'?)",
        ),
        (
            "arena:\n  wall:\n    color: [300, 0, 0]\n",
            3,
            ("arena", "wall", "color"),
            "outside 0-255",
        ),
        (
            "items:\n  - {name: fruits, color: orange, reward: ten, count: 3}\n",
            2,
            ("items", 0, "reward"),
            "valid number",
        ),
        ("obstacles:\n  - {shape: star, position: [1, 1]}\n", 2, ("obstacles", 0), "'star'"),
        (
            "obstacles:\n  - shape: polygon\n    position: [50, 50]\n    vertices: [[0, 0], [10, 10], [10, 0], [0, 10]]\n",
            2,
            ("obstacles", 0),
            "convex",
        ),
        (
            "obstacles:\n  - {shape: circle, position: [5, 50], radius: 10}\n",
            2,
            ("obstacles", 0, "position"),
            "outside the 300 x 300 arena",
        ),
        (
            "obstacles:\n  - {shape: box, position: [100, 100], size: [40, 40]}\n  - {shape: circle, position: [120, 100], radius: 10}\n",
            3,
            ("obstacles", 1),
            "overlaps another obstacle",
        ),
        (
            "items:\n  - {name: fruits, color: orange, reward: 1, count: 5000, radius: 10}\n",
            2,
            ("items", 0, "count"),
            "no room",
        ),
        (
            "items:\n  - {name: a, color: red, reward: 1, count: 1}\n  - {name: a, color: red, reward: 1, count: 1}\n",
            3,
            ("items", 1, "name"),
            "used twice",
        ),
        ("n_agents: 60\nagent:\n  radius: 40\n", 1, ("n_agents",), "no room to place every agent"),
        # spawn areas outside the arena, or with no free room
        (
            "agent:\n  spawn: {area: [250, 250, 350, 350]}\n",
            2,
            ("agent", "spawn", "area"),
            "outside the 300 x 300 arena",
        ),
        (
            "items:\n  - {name: a, color: red, count: 2, spawn: [-10, 0, 50, 50]}\n",
            2,
            ("items", 0, "spawn"),
            "outside",
        ),
        (
            "zones:\n  - {size: [20, 20], area: [0, 0, 400, 50]}\n",
            2,
            ("zones", 0, "area"),
            "outside",
        ),
        ("zones:\n  - {rect: [0, 0, 20, 20], size: [5, 5]}\n", 2, ("zones", 0), "either a 'rect'"),
        ("rooms:\n  - {rect: [200, 200, 320, 280]}\n", 2, ("rooms", 0, "rect"), "outside"),
        ("rooms:\n  - {rect: [200, 200, 100, 280]}\n", 2, ("rooms", 0, "rect"), "x1 > x0"),
        (
            "obstacles:\n  - {shape: box, position: [150, 150], size: [280, 280]}\n",
            1,
            ("arena", "size"),
            "no free place where agents could start",
        ),
        (
            "obstacles:\n  - {shape: circle, position: [50, 150], radius: 10}\nwalls:\n  - {start: [50, 0], end: [50, 300]}\n",
            2,
            ("obstacles", 0),
            "overlaps a wall",
        ),
        # items nobody can reach
        (
            "walls:\n  - {start: [150, 0], end: [150, 300]}\nagent:\n  spawn: {area: [0, 0, 140, 300]}\nitems:\n  - {name: a, color: red, count: 1, spawn: [160, 0, 300, 300]}\n",
            6,
            ("items", 0, "spawn"),
            "no free place in the area that agents can reach",
        ),
        (
            "walls:\n  - {start: [150, 0], end: [150, 300]}\nagent:\n  spawn: {area: [0, 0, 140, 300]}\nitems:\n  - {name: a, color: red, positions: [[200, 150]]}\n",
            6,
            ("items", 0, "positions", 0),
            "agents cannot reach",
        ),
        # doors, keys, switches
        (
            "doors:\n  - {start: [150, 0], end: [150, 40], state: locked}\n",
            2,
            ("doors", 0),
            "needs a 'key' or a 'switch'",
        ),
        (
            "doors:\n  - {start: [150, 0], end: [150, 40], state: locked, key: gold}\n",
            2,
            ("doors", 0, "key"),
            "no key item group or key object 'gold'",
        ),
        (
            "doors:\n  - {start: [150, 0], end: [150, 40], switch: plate}\n",
            2,
            ("doors", 0, "switch"),
            "no zone named 'plate'",
        ),
        (
            "doors:\n  - {kind: hinged, key: k, start: [150, 0], end: [150, 40]}\n",
            2,
            ("doors", 0),
            "pushed open",
        ),
        ("doors:\n  - {state: closed}\n", 2, ("doors", 0), "needs 'start' and 'end'"),
        (
            "corridors:\n  - {start: [0, 0], end: [100, 100]}\n",
            2,
            ("corridors", 0),
            "horizontally or vertically",
        ),
        ("walls:\n  - {start: [10, 10], end: [10, 10]}\n", 2, ("walls", 0), "0.1 apart"),
        (
            "walls:\n  - {start: [100, 10], end: [100, 200], thickness: 0.5}\nagent:\n  max_speed: 800\n",
            2,
            ("walls", 0, "thickness"),
            "can be crossed",
        ),
        ("items:\n  - {name: score, color: red}\n", 2, ("items", 0, "name"), "reserved"),
        (
            "episode:\n  end_when_eaten: gold\n",
            2,
            ("episode", "end_when_eaten"),
            "no item group 'gold'",
        ),
        (
            "layout:\n  generators:\n    - {generator: tunnels}\n",
            3,
            ("layout", "generators", 0),
            "'tunnels'",
        ),
        (
            "layout:\n  generators:\n    - {generator: maze, cel: 20}\n",
            3,
            ("layout", "generators", 0, "cel"),
            "did you mean 'cell'",
        ),
        (
            "layout:\n  generators:\n    - {generator: random_obstacles, count: 400, size: [40, 60]}\n",
            3,
            ("layout", "generators", 0, "count"),
            "could not place 400 obstacles",
        ),
        (
            "items:\n  - {name: a, color: red, texture: {kind: plaid}}\n",
            2,
            ("items", 0, "texture", "kind"),
            "'uniform'",
        ),
        # keys and switches behind the doors they open; zones nobody can reach
        (
            KEY_DOOR + "items:\n  - {name: key, color: gold, key: true, positions: [[340, 60]]}\n",
            9,
            ("items", 0, "positions", 0),
            "agents cannot reach this place (behind doors[0]",
        ),
        (
            KEY_DOOR
            + "items:\n  - {name: key, color: gold, key: true, spawn: [20, 20, 380, 230]}\n",
            9,
            ("items", 0, "spawn"),
            "may be drawn where agents can only go through doors[0], which it opens",
        ),
        (
            SWITCH_DOOR + "zones:\n  - {name: plate, rect: [300, 20, 340, 60]}\n",
            9,
            ("zones", 0, "rect"),
            "agents cannot reach this zone (behind doors[0]",
        ),
        (
            SWITCH_DOOR + "zones:\n  - {name: plate, size: [40, 40], area: [100, 20, 390, 230]}\n",
            9,
            ("zones", 0, "area"),
            "which it opens",
        ),
        (
            "walls:\n  - {start: [150, 0], end: [150, 300]}\nagent:\n  spawn: {area: [0, 0, 140, 300]}\nzones:\n  - {rect: [200, 100, 240, 140], reward: 1}\n",
            6,
            ("zones", 0, "rect"),
            "agents cannot reach this zone",
        ),
        # room to place things, reported at the key that asks for too much
        (
            "n_agents: 4\nteams:\n  - {name: a, size: 2}\n  - {name: b, size: 2, spawn: {area: [100, 100, 112, 112]}}\n",
            4,
            ("teams", 1, "spawn", "area"),
            "no room to place every agent",
        ),
        ("agent:\n  radius: 1000\n", 2, ("agent", "radius"), "do not fit in the 300 x 300 arena"),
        (
            "items:\n  - {name: a, color: red, radius: 1000}\n",
            2,
            ("items", 0, "radius"),
            "do not fit in the 300 x 300 arena",
        ),
        (
            "obstacles:\n  - {shape: box, position: [150, 150], size: [200, 200]}\nitems:\n  - {name: a, color: red, radius: 60}\n",
            4,
            ("items", 0, "radius"),
            "no room to place every item",
        ),
        (
            "extends: fruits_poisons\nitems:\n  - {name: a, color: red, radius: 10, count: 100}\n",
            3,
            ("items", 0, "count"),
            "no room to place every item",
        ),
        # fixed items apart, openings on their sides
        (
            "items:\n  - {name: a, color: red, positions: [[100, 100]]}\n  - {name: b, color: red, positions: [[200, 200], [105, 100]]}\n",
            3,
            ("items", 1, "positions", 1),
            "overlaps the item at items[0].positions[0]",
        ),
        (
            "rooms:\n  - {rect: [50, 50, 150, 150], openings: [{side: north, offset: 90, width: 40}]}\n",
            2,
            ("rooms", 0, "openings", 0, "offset"),
            "the gap from 70 to 110 along the north side does not fit in the side, 100 long",
        ),
    ],
)
def test_faults_are_located(tmp_path, text, line, path, words):
    path_ = write(tmp_path, text)
    found = problems(path_)
    match = [p for p in found if p.path == path]
    assert match, f"no problem at {path}: {[str(p) for p in found]}"
    assert match[0].line == line and match[0].source == str(path_)
    assert words in match[0].message
