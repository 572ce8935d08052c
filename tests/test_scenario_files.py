"""Scenario files: every shipped file validates; every fault is reported with the file,
the line and the key path (malformed files are fuzzed in ``test_scenario_fuzz.py``)."""

import textwrap

import numpy as np
import pytest

import flatland_ma
from flatland_ma.scenario import builder, capacity
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import load_scenario, scenario_dir

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


def write(tmp_path, text, name="s.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def problems(path, **overrides):
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, **overrides)
    return info.value.problems


@pytest.mark.parametrize("name", flatland_ma.list_scenarios())
def test_every_shipped_scenario_validates_and_describes_itself(name):
    spec = load_scenario(name)
    assert spec.description
    text = (scenario_dir() / f"{name}.yaml").read_text()
    assert text.startswith("# "), "each file starts with a comment saying what the task is"


def test_unknown_key_names_file_line_path_and_suggests(tmp_path):
    path = write(
        tmp_path,
        """\
        description: test
        obstacles:
          - shape: circle
            position: [50, 50]
            radus: 10
        """,
    )
    (p,) = [p for p in problems(path) if "radus" in str(p)]
    assert p.source == str(path) and p.line == 5 and p.path == ("obstacles", 0, "radus")
    assert "unknown key 'radus'" in str(p) and "did you mean 'radius'" in str(p)
    assert str(p).startswith(f"{path}:5: obstacles[0].radus:")
    # ... and the missing radius is reported too, at the obstacle's line.
    assert any(
        q.path == ("obstacles", 0, "radius") and "missing" in q.message for q in problems(path)
    )


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
            "unknown colour name 'oragne'",
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
        ("walls:\n  - {start: [10, 10], end: [10, 10]}\n", 2, ("walls", 0), "distinct"),
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


def test_yaml_syntax_errors_and_duplicate_keys(tmp_path):
    (p,) = problems(write(tmp_path, "n_agents: 1\narena: {size: [1, 2]\n"))
    assert "not valid YAML" in p.message and p.line == 3
    (p,) = problems(write(tmp_path, "n_agents: 1\nn_agents: 2\n"))
    assert p.line == 2 and "key given twice" in p.message
    (p,) = problems(write(tmp_path, "- 1\n- 2\n"))
    assert "mapping" in p.message
    (p,) = problems(write(tmp_path, "n_agents: !!python/object:os.system 1\n"))
    assert p.line == 1
    assert problems(write(tmp_path, "1: 2\n"))[0].message == "keys must be plain words"


def test_extends_merges_over_the_base_and_reports_the_right_file(tmp_path):
    child = write(tmp_path, "extends: fruits_poisons\nn_agents: 3\nagent:\n  camera: {rays: 16}\n")
    spec = load_scenario(child)
    base = load_scenario("fruits_poisons")
    assert spec.n_agents == 3 and spec.agent.camera.rays == 16
    assert spec.agent.camera.fov == base.agent.camera.fov and spec.obstacles == base.obstacles
    bad = write(tmp_path, "extends: fruits_poisons\nagent:\n  camera: {rays: -1}\n", "bad.yaml")
    (p,) = problems(bad)
    assert p.source == str(bad) and p.line == 3 and p.path == ("agent", "camera", "rays")
    (p,) = problems(write(tmp_path, "extends: nowhere\n", "orphan.yaml"))
    assert "unknown scenario 'nowhere'" in p.message and p.path == ("extends",)
    loop = write(tmp_path, f"extends: {tmp_path / 'loop.yaml'}\n", "loop.yaml")
    assert "cycle" in problems(loop)[0].message


def test_overrides_merge_like_a_file_and_are_validated_the_same_way():
    spec = load_scenario("fruits_poisons", n_agents=2, agent={"camera": {"rays": 128}})
    assert spec.n_agents == 2 and spec.agent.camera.rays == 128 and spec.agent.camera.fov == 120
    spec = load_scenario("fruits_poisons", obstacles=[])
    assert spec.obstacles == ()
    with pytest.raises(ScenarioError) as info:
        load_scenario("fruits_poisons", agent={"camera": {"rays": "many"}})
    (p,) = info.value.problems
    assert p.source == "<overrides>" and p.line is None and p.path == ("agent", "camera", "rays")
    assert str(p).startswith("<overrides>: agent.camera.rays:")
    with pytest.raises(ScenarioError, match="unknown key 'n_agent'"):
        flatland_ma.parallel_env("fruits_poisons", n_agent=2)


def test_validate_command_reports_and_fails(tmp_path, capsys):
    from flatland_ma.cli import main

    good = write(tmp_path, "description: fine\n", "good.yaml")
    bad = write(tmp_path, "n_agents: x\n", "bad.yaml")
    assert main(["validate", str(good), "fruits_poisons"]) == 0
    assert main(["validate", str(good), str(bad)]) == 1
    out = capsys.readouterr().out
    assert f"{bad}:1: n_agents:" in out and "ok (1 agent(s)" in out


def test_doors_open_in_the_order_their_keys_can_be_reached(tmp_path):
    """Three rooms in a row behind two locked doors; each key must lie before its door."""
    arena = """\
arena: {size: [600, 250]}
walls:
  - {start: [200, 0], end: [200, 250]}
  - {start: [400, 0], end: [400, 250]}
doors:
  - {start: [200, 105], end: [200, 145], state: locked, key: first}
  - {start: [400, 105], end: [400, 145], state: locked, key: second}
agent:
  spawn: {area: [20, 20, 180, 230]}
items:
  - {name: first, color: gold, key: true, positions: [[FIRST, 60]]}
  - {name: second, color: gold, key: true, positions: [[SECOND, 60]]}
  - {name: goal, color: lime, positions: [[500, 125]]}
"""

    def keys_at(first, second):
        return arena.replace("FIRST", str(first)).replace("SECOND", str(second))

    assert load_scenario(write(tmp_path, keys_at(100, 300))).doors
    (p,) = problems(write(tmp_path, keys_at(300, 100)))
    assert p.path == ("items", 0, "positions", 0) and p.line == 11
    assert p.message == (
        "agents cannot reach this place (behind doors[0]: it never opens, nothing that "
        "opens it is reachable)"
    )


def test_an_obstacle_overlapping_a_wall_names_the_wall_too(tmp_path):
    with pytest.raises(ScenarioError) as info:
        load_scenario("fruits_poisons", walls=[{"start": [60, 0], "end": [60, 300]}])
    obstacle, wall = info.value.problems
    assert obstacle.path == ("obstacles", 0) and "overlaps a wall (walls[0])" in obstacle.message
    assert wall.source == "<overrides>" and wall.path == ("walls", 0)
    assert wall.message == "overlaps obstacles[0]"


def test_a_union_field_gives_one_message(tmp_path):
    (p,) = problems(write(tmp_path, "items:\n  - {name: a, color: red, respawn: 0}\n"))
    assert p.path == ("items", 0, "respawn") and p.line == 2
    assert (
        p.message == "Input should be 'immediate' or 'never', or greater than or equal to 1; got 0"
    )


def test_an_unknown_key_in_an_optional_section_lists_that_sections_keys(tmp_path):
    (p,) = problems(write(tmp_path, "agent:\n  head:\n    radios: 3\n"))
    assert p.path == ("agent", "head", "radios") and p.line == 3
    assert "did you mean 'radius'" in p.message and "max_angle" in p.message


def test_numpy_numbers_are_accepted_as_overrides():
    spec = load_scenario("fruits_poisons", n_agents=np.int64(2), agent={"radius": np.float32(8.0)})
    assert spec.n_agents == 2 and type(spec.n_agents) is int and spec.agent.radius == 8.0
    spec = load_scenario("fruits_poisons", arena={"size": np.array([320.0, 300.0])})
    assert spec.arena.size == (320.0, 300.0)


def test_the_validate_summary_counts_items_at_fixed_places(tmp_path, capsys):
    from flatland_ma.cli import main

    path = write(
        tmp_path, "items:\n  - {name: a, color: red, positions: [[50, 50], [90, 50], [130, 50]]}\n"
    )
    assert main(["validate", str(path)]) == 0
    assert "3 items)" in capsys.readouterr().out


def test_random_obstacles_cut_off_no_team_from_its_spawn_area(monkeypatch):
    starts = []

    def recording(gen, world, grid, start, rng, path):
        starts.append((grid, start))
        return scatter(gen, world, grid, start, rng, path)

    scatter = builder.scatter_obstacles
    monkeypatch.setattr(builder, "scatter_obstacles", recording)
    layout = {"generators": [{"generator": "random_obstacles", "count": 3}]}
    # Nobody starts in agent.spawn (each team has its own area): only the teams' count.
    spec = load_scenario("tug_of_war", layout=layout, agent={"spawn": {"area": [240, 0, 260, 20]}})
    grid, start = starts[0]
    for team in spec.teams:
        assert start[grid.cells_in(team.spawn.area)].all()
    assert not (start & grid.cells_in(spec.agent.spawn.area)).any()


def test_a_placement_that_fails_at_reset_names_the_file_and_key(tmp_path, monkeypatch):
    """Loading checks a few seeds with room to spare; with those checks loosened, a reset
    that finds no room raises a located ScenarioError, not a bare error from the builder."""
    monkeypatch.setattr(capacity, "MAX_COVER", 1.0)
    monkeypatch.setattr(builder, "CHECK_SEEDS", 1)
    text = "extends: fruits_poisons\nitems:\n  - {name: a, color: red, radius: 10, count: 100}\n"
    env = flatland_ma.parallel_env(write(tmp_path, text))
    failures = []
    for seed in range(1, 20):
        try:
            env.reset(seed=seed)
        except ScenarioError as err:
            failures += err.problems
    assert failures, "expected some seed to run out of room"
    p = failures[0]
    assert p.source == str(tmp_path / "s.yaml") and p.line == 3
    assert p.path == ("items", 0, "count") and "no room to place every item" in p.message


@pytest.mark.parametrize("document", ["README.md", "docs/scenarios.md"])
def test_the_yaml_examples_in_the_docs_are_valid_scenarios(tmp_path, document):
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / document).read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", text, re.S)
    assert blocks
    for k, block in enumerate(blocks):
        path = tmp_path / f"example_{k}.yaml"
        path.write_text(block)
        env = flatland_ma.parallel_env(path)
        env.reset(seed=0)
        env.step({a: env.action_space(a).sample() for a in env.agents})
